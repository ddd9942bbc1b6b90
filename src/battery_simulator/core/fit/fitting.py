"""The fits (no ROS): what a robot's logs identify of its battery, the rest kept from the chemistry preset.

    fit(logs, chemistry) -> FitResult

Order: the series count (from the voltage range, each candidate fitted), the capacity and each log's
starting SOC with the OCV of the preset's shape (its offset where the log has a rest), the resistances
and RC pairs (least squares for given time constants, the constants searched), where that shape does not
fit and the logs cover enough charge the OCV curve itself over the covered range, the idle and motion
loads (battery current against cmd_vel), the charger (a charge's CC current and CV voltage) and the
heat (the logged temperature). Each value carries its source and a 1-sigma uncertainty from the fit.
"""
import itertools
import math
from dataclasses import dataclass, replace

import numpy as np

from battery_simulator.core.fit import FitError
from battery_simulator.core.fit.circuit import (Chemistry, hat_basis, log_arrays, regressors, state_of_charge,
                                                 thermal)
from battery_simulator.core.parameters import MAX_CELLS, ParameterError

#: the held-out part of each log (its last fraction), by default
DEFAULT_HOLDOUT = 0.25
#: a rest: |current| below this fraction of the log's largest (or REST_A) for at least REST_S
REST_FRACTION, REST_A, REST_S = 0.02, 0.05, 120.0
#: the OCV curve is learned where the logs cover at least LEARN_MIN_SOC_SPAN of the charge range and the
#: learned curve predicts each of CV_FOLDS blocks of the fitted part, held out in turn, better than the
#: preset's shape: its cross-validated RMSE below LEARN_GAIN times the shape's
LEARN_MIN_SOC_SPAN, LEARN_GAIN, CV_FOLDS = 0.05, 0.9, 5
#: the smoothness weights tried (the learned curvature's departure from the preset's, per knot, relative to
#: the data's weight): the one that cross-validates best is kept
SMOOTHNESS = (0.001, 0.003, 0.01, 0.03, 0.1, 0.3, 1.0, 3.0)
#: knots of a learned OCV curve: one per this much SOC, between these counts
LEARN_KNOT_SOC, LEARN_MIN_KNOTS, LEARN_MAX_KNOTS = 0.02, 4, 40
#: a charge: charging current for at least this long, s
CHARGE_MIN_S = 120.0
#: the logged percentage gives the capacity beside a learned OCV curve when it moves by this much
PERCENTAGE_SPAN = 0.1
#: the series count is clear when the runner-up's fit is this many times worse than the best's
SERIES_CLEAR = 1.5
#: samples per log the series-count search looks at
SEARCH_SAMPLES = 2500
#: bounds of the searched time constants, s
TAU1_BOUNDS, TAU_FAST_BOUNDS = (60.0, 20000.0), (2.0, 200.0)


@dataclass
class Fitted:
    """One value written to the config: how it was found and how well (None: not estimated)."""

    value: object
    source: str
    uncertainty: float = None


@dataclass
class FitResult:
    params: object                 # BatteryParameters of the fitted battery
    chemistry: str
    fitted: dict                   # name -> Fitted
    kept: dict                     # name -> why the preset's value stays
    warnings: list
    logs: list                     # the FitLogs
    initial_soc: list              # per log
    fit_masks: list                # per log: the samples fitted (the rest held out)


def fit(logs, chemistry_params, chemistry_name, cells_series=None, holdout=DEFAULT_HOLDOUT, progress=None):
    """A FitResult for ``logs`` (FitLogs of one robot) over the chemistry preset's parameters."""
    progress = progress or (lambda fraction, text: None)
    chemistry = Chemistry(chemistry_params)
    warnings = []
    masks = [_fit_mask(log, holdout) for log in logs]
    fitted, kept = {}, {}
    # -- series count
    progress(0.02, 'series count')
    if cells_series is None:
        cells_series, why = _series_count(logs, masks, chemistry, progress, warnings)
    else:
        why = 'given (--cells-series)'
    fitted['cells_series'] = Fitted(cells_series, why)
    # -- the electrical fit, with the model's temperature
    progress(0.25, 'capacity and resistances')
    has_rest = any(_has_rest(log, mask) for log, mask in zip(logs, masks))
    temperatures = [_preset_temperature(log, chemistry) for log in logs]
    electrical = _fit_electrical(logs, masks, chemistry, cells_series, 1, temperatures, has_rest, None)
    cells_parallel = min(MAX_CELLS, max(1, int(round(electrical.capacity_ah / chemistry_params.cell_capacity_ah))))
    heat_params = _fit_thermal(logs, masks, chemistry, cells_parallel, electrical, fitted, kept)
    temperatures = [_model_temperature(log, chemistry, cells_parallel, electrical, heat_params) for log in logs]
    progress(0.55, 'capacity and resistances (with the heat)')
    electrical = _fit_electrical(logs, masks, chemistry, cells_series, cells_parallel, temperatures, has_rest,
                                 electrical)
    progress(0.75, 'OCV curve')
    curve = _learn_curve(logs, masks, chemistry, temperatures, electrical, has_rest)
    for rounds in range(2):
        if curve is None:
            break
        # its resistances and time constants, the heat they make, the temperature, and the curve again at it
        coefficients = dict(electrical.coefficients)
        coefficients.update((name, (value, curve['sigmas'].get(name))) for name, value in curve['resistances'].items())
        electrical = replace(electrical, tau1_s=curve['tau1_s'], tau_fast_s=curve['tau_fast_s'], soc0=curve['soc0'],
                             coefficients=coefficients, capacity_ah=curve['capacity_ah'])
        heat_params = _fit_thermal(logs, masks, chemistry, cells_parallel, electrical, fitted, kept)
        if rounds == 0 and any(log.temperature_c is not None for log in logs):
            temperatures = [_model_temperature(log, chemistry, cells_parallel, electrical, heat_params) for log in logs]
            curve = _learn_curve(logs, masks, chemistry, temperatures, electrical, has_rest) or curve
        else:
            break
    changes = _electrical_values(electrical, curve, chemistry, cells_series, cells_parallel, has_rest,
                                 fitted, kept, warnings)
    progress(0.9, 'loads and charger')
    changes.update(_fit_loads(logs, masks, cells_series, chemistry_params, fitted, kept))
    changes.update(_fit_charger(logs, masks, cells_series, cells_parallel, chemistry_params, changes, fitted, kept))
    changes.update(heat_params['changes'])
    changes.update(_limits(logs, cells_series, cells_parallel, chemistry_params, changes, fitted))
    changes['cells_series'] = cells_series
    changes['cells_parallel'] = cells_parallel
    changes['name'] = 'fitted'
    changes['source'] = 'battery_fit from %d log%s over the %s preset' % (len(logs), 's' * (len(logs) > 1),
                                                                          chemistry_name)
    try:
        params = replace(chemistry_params, **changes)
    except ParameterError as error:
        raise FitError('the fitted values break the model\'s rules (%s): the log cannot be fitted with the %s '
                       'preset; try --chemistry or --cells-series' % (error, chemistry_name)) from None
    for name, value in changes.items():
        if isinstance(value, float) and not math.isfinite(value):
            raise FitError('the fit gave %s = %r: the log cannot be fitted' % (name, value))
    progress(1.0, 'done')
    return FitResult(params=params, chemistry=chemistry_name, fitted=fitted, kept=kept, warnings=warnings,
                     logs=logs, initial_soc=list(electrical.soc0), fit_masks=masks)


# -- the parts ------------------------------------------------------------------------------------------

def _fit_mask(log, holdout):
    t = log.time_s
    mask = t <= t[-1] * (1.0 - holdout) if holdout > 0 else np.ones(len(t), dtype=bool)
    if mask.sum() < 10:
        raise FitError('%s: too short to fit with %g held out: %d samples before the held-out part'
                       % (log.name, holdout, mask.sum()))
    return mask


def _has_rest(log, mask):
    i, t = np.abs(log.current_a[mask]), log.time_s[mask]
    still = i <= max(REST_A, REST_FRACTION * i.max())
    # the longest run of still samples
    best, start = 0.0, None
    for k in range(len(i)):
        if still[k]:
            start = t[k] if start is None else start
            best = max(best, t[k] - start)
        else:
            start = None
    return best >= REST_S


def _preset_temperature(log, chemistry):
    if log.temperature_c is not None:
        return log.temperature_c
    return np.full(len(log.time_s), chemistry.params.ambient_temperature_c)


def _series_count(logs, masks, chemistry, progress, warnings):
    p = chemistry.params
    high = max(float(np.max(log.voltage_v)) for log in logs)
    low = min(float(np.min(log.voltage_v)) for log in logs)
    top, bottom = p.ocv_voltage_v[-1] + 0.15, max(0.5 * p.ocv_voltage_v[0], p.ocv_voltage_v[0] - 0.4)
    candidates = list(range(max(1, math.ceil(high / top)), int(low / bottom) + 1))
    middle = 0.5 * (p.ocv_voltage_v[0] + p.ocv_voltage_v[-1])
    candidates.sort(key=lambda n: abs(n - 0.5 * (high + low) / middle))
    candidates = sorted(candidates[:8]) or [max(1, int(round(high / p.ocv_voltage_v[-1])))]
    if len(candidates) == 1:
        return candidates[0], 'the voltage range (%.2f-%.2f V) allows only this count' % (low, high)
    short_logs, short_masks = [], []
    for log, mask in zip(logs, masks):
        step = max(1, len(log.time_s) // SEARCH_SAMPLES)
        short_logs.append(_thinned(log, step))
        short_masks.append(mask[::step])
    scores = []
    for index, count in enumerate(candidates):
        temperatures = [_preset_temperature(log, chemistry) for log in short_logs]
        try:
            result = _fit_electrical(short_logs, short_masks, chemistry, count, 1, temperatures, True, None,
                                     max_evaluations=60)
            scores.append((result.rmse_v * count, count))   # pack volts: comparable across counts
        except FitError:
            pass
        progress(0.02 + 0.2 * (index + 1) / len(candidates), 'series count')
    if not scores:
        raise FitError('no series count fits the voltage range %.2f-%.2f V with the %s preset'
                       % (low, high, p.name))
    scores.sort()
    best = scores[0][1]
    if len(scores) > 1 and scores[1][0] < SERIES_CLEAR * scores[0][0]:
        warnings.append('cells in series: %d fits the %s shape best, but %d nearly as well (the pack voltage '
                        '%.4g-%.4g V puts every cell within 2.5-4.35 V for %s cells); a pack of other cells can '
                        'be either: --cells-series settles it' % (best, p.name, scores[1][1], low, high,
                                                                 ', '.join(str(n) for n in candidates)))
    return best, 'the voltage range %.2f-%.2f V and the best fit of the OCV shape among %s cells' % (
        low, high, ', '.join(str(n) for n in candidates))


def _thinned(log, step):
    copy = replace(log)
    for name in ('time_s', 'voltage_v', 'current_a', 'temperature_c', 'percentage'):
        value = getattr(log, name)
        if value is not None:
            setattr(copy, name, value[::step])
    if step > 1:   # a thinned log's current: the mean over each new interval (the charge is kept)
        t = log.time_s
        charge = np.concatenate([[0.0], np.cumsum(log.current_a[1:] * np.diff(t))])
        picked = charge[::step]
        span = np.diff(copy.time_s)
        copy.current_a = np.concatenate([[log.current_a[0]], np.diff(picked) / np.where(span > 0, span, 1.0)])
    return copy


@dataclass
class Electrical:
    capacity_ah: float             # pack
    soc0: list
    tau1_s: float
    tau_fast_s: float
    coefficients: dict             # offset, r0, r1, r_fast (per cell), with sigma
    rmse_v: float                  # per cell, on the fitted samples
    use_tables: bool
    uncertainty: dict              # capacity_ah, tau1_s, tau_fast_s sigmas
    pieces: list                   # per log: (arrays, soc, ocv, x0, x1, xf) at the solution
    cells_series: int
    cells_parallel: int


def _fit_electrical(logs, masks, chemistry, cells_series, cells_parallel, temperatures, has_rest, start,
                    max_evaluations=200):
    from scipy.optimize import least_squares
    p = chemistry.params
    arrays = [log_arrays(log, chemistry, cells_series, cells_parallel) for log in logs]
    scales = [chemistry.arrhenius(temperature) for temperature in temperatures]
    if start is None:
        soc0 = [_soc_guess(chemistry, a.cell_voltage[0]) for a in arrays]
        capacity = _capacity_guess(logs, arrays, chemistry, soc0)
        z0 = [math.log(capacity)] + soc0 + [math.log(p.tau1_s), math.log(p.tau_fast_s)]
    else:
        z0 = [math.log(start.capacity_ah)] + list(start.soc0) + [math.log(start.tau1_s), math.log(start.tau_fast_s)]
    n = len(logs)
    low = [z0[0] - math.log(20.0)] + [0.0] * n + [math.log(TAU1_BOUNDS[0]), math.log(TAU_FAST_BOUNDS[0])]
    high = [z0[0] + math.log(20.0)] + [1.0] * n + [math.log(TAU1_BOUNDS[1]), math.log(TAU_FAST_BOUNDS[1])]
    z0 = np.clip(z0, np.asarray(low) + 1e-9, np.asarray(high) - 1e-9)
    best = {}

    def solve(z, use_tables):
        capacity = math.exp(z[0])
        tau1, tau_fast = math.exp(z[-2]), math.exp(z[-1])
        pieces, rows, targets = [], [], []
        for k, a in enumerate(arrays):
            soc = state_of_charge(a, capacity / cells_parallel, z[1 + k], p.coulombic_efficiency)
            ocv = chemistry.ocv_at(soc, a.weight)
            x0, x1, xf = regressors(a, soc, scales[k], chemistry, tau1, tau_fast, use_tables)
            pieces.append((a, soc, ocv, x0, x1, xf))
            m = masks[k]
            columns = [x0[m], x1[m], xf[m]]
            if has_rest:
                columns.insert(0, np.ones(m.sum()))
            rows.append(np.column_stack(columns))
            targets.append(a.cell_voltage[m] - ocv[m])
        design, target = np.vstack(rows), np.concatenate(targets)
        names = (['offset'] if has_rest else []) + ['r0_ohm', 'r1_ohm', 'r_fast_ohm']
        values, sigmas, residual = _non_negative_lstsq(design, target, names)
        return pieces, values, sigmas, residual

    def residuals(z, use_tables):
        return solve(z, use_tables)[3]

    results = []
    for use_tables in (True, False) if chemistry.table_soc is not None else (False,):
        solution = least_squares(residuals, z0, bounds=(low, high), args=(use_tables,), x_scale='jac',
                                 diff_step=1e-4, max_nfev=max_evaluations)
        pieces, values, sigmas, residual = solve(solution.x, use_tables)
        rmse = float(np.sqrt(np.mean(residual ** 2)))
        results.append((rmse, use_tables, solution, pieces, values, sigmas))
    # the preset's SOC tables only where they explain the log better (else the simpler circuit)
    rmse, use_tables, solution, pieces, values, sigmas = min(results, key=lambda r: r[0] * (1.0 + 0.02 * r[1]))
    best = dict(values)
    best.setdefault('offset', 0.0)
    uncertainty = _jacobian_sigmas(solution, rmse)
    return Electrical(capacity_ah=math.exp(solution.x[0]), soc0=[float(s) for s in solution.x[1:1 + n]],
                      tau1_s=math.exp(solution.x[-2]), tau_fast_s=math.exp(solution.x[-1]),
                      coefficients={k: (best[k], sigmas.get(k)) for k in best}, rmse_v=rmse, use_tables=use_tables,
                      uncertainty={'capacity_ah': math.exp(solution.x[0]) * uncertainty[0],
                                   'tau1_s': math.exp(solution.x[-2]) * uncertainty[-2],
                                   'tau_fast_s': math.exp(solution.x[-1]) * uncertainty[-1]},
                      pieces=pieces, cells_series=cells_series, cells_parallel=cells_parallel)


def _jacobian_sigmas(solution, rmse):
    jacobian = solution.jac
    try:
        covariance = np.linalg.pinv(jacobian.T @ jacobian) * rmse ** 2
        return np.sqrt(np.maximum(np.diag(covariance), 0.0))
    except np.linalg.LinAlgError:
        return np.full(len(solution.x), np.nan)


def _non_negative_lstsq(design, target, names):
    """Least squares with the resistances >= 0 (the offset free): dropping a negative one at a time.
    Returns ({name: value}, {name: sigma}, residual)."""
    active = list(range(len(names)))
    while True:
        values, *_ = np.linalg.lstsq(design[:, active], target, rcond=None)
        negative = [(values[j], j) for j, col in enumerate(active) if names[col] != 'offset' and values[j] < 0]
        if not negative or len(active) == 1:
            break
        active.pop(min(negative)[1])
    residual = target - design[:, active] @ values
    dof = max(1, len(target) - len(active))
    try:
        covariance = np.linalg.inv(design[:, active].T @ design[:, active]) * float(residual @ residual) / dof
        sigma = np.sqrt(np.maximum(np.diag(covariance), 0.0))
    except np.linalg.LinAlgError:
        sigma = np.full(len(active), np.nan)
    result = {name: 0.0 for name in names}
    sigmas = {}
    for j, col in enumerate(active):
        result[names[col]] = float(values[j])
        sigmas[names[col]] = float(sigma[j])
    return result, sigmas, residual


def _soc_guess(chemistry, cell_voltage):
    soc = np.interp(cell_voltage, chemistry.ocv, chemistry.soc_points)
    return float(np.clip(soc, 0.02, 0.98))


def _capacity_guess(logs, arrays, chemistry, soc0):
    """Charge counted over the SOC change the voltages suggest, else the preset cell's."""
    guesses = []
    for log, a, start in zip(logs, arrays, soc0):
        end = _soc_guess(chemistry, a.cell_voltage[-1])
        charge_ah = float(np.sum(a.cell_current * a.dt)) / 3600.0
        if abs(end - start) > 0.15 and charge_ah * (end - start) > 0:
            guesses.append(charge_ah / (end - start))
    if guesses:
        return float(np.median(guesses))
    throughput = max(float(np.sum(np.abs(a.cell_current) * a.dt)) / 3600.0 for a in arrays)
    return max(chemistry.params.cell_capacity_ah, 1.2 * throughput)


def _learn_curve(logs, masks, chemistry, temperatures, electrical, has_rest):
    """The OCV at knots over the covered SOC range, when the logs cover enough of it and the learned curve
    predicts blocks of the fitted part held out in turn better than the preset's shape (else None).
    Returns {knots, values, rmse_v, resistances, sigmas, gap, smoothness, cv: (preset, curve) RMSEs, taus}."""
    socs = np.concatenate([piece[1][mask] for piece, mask in zip(electrical.pieces, masks)])
    low, high = float(np.min(socs)), float(np.max(socs))
    if high - low < LEARN_MIN_SOC_SPAN:
        return None
    count = int(np.clip(round((high - low) / LEARN_KNOT_SOC), LEARN_MIN_KNOTS, LEARN_MAX_KNOTS)) + 1
    knots = np.linspace(low, high, count)
    shape = np.interp(knots, chemistry.soc_points, chemistry.ocv)
    folds, voltage, gaps, preset_ocv, currents, hats = [], [], [], [], [], []
    for (a, soc, ocv, x0, x1, xf), mask in zip(electrical.pieces, masks):
        n = int(mask.sum())
        folds.append((np.arange(n) * CV_FOLDS) // n)   # contiguous blocks of each log's fitted part
        voltage.append(a.cell_voltage[mask])
        gaps.append((np.interp(soc, chemistry.soc_points, chemistry.gap) * a.weight)[mask])
        preset_ocv.append(ocv[mask])
        currents.append(np.column_stack([x0[mask], x1[mask], xf[mask]]))
        hats.append(hat_basis(soc[mask], knots))
    fold, voltage, gaps = np.concatenate(folds), np.concatenate(voltage), np.concatenate(gaps)
    resistive = np.vstack(currents)
    preset_design = np.column_stack(([np.ones(len(voltage))] if has_rest else []) + [resistive])
    preset_cv = _cross_validated(preset_design, voltage - np.concatenate(preset_ocv), fold, None, None)
    design = np.hstack([np.vstack(hats), resistive])
    scale = math.sqrt(len(voltage) / count)
    smooth = np.zeros((count - 2, design.shape[1]))
    for j in range(count - 2):
        smooth[j, j:j + 3] = (1.0, -2.0, 1.0)
    smooth_target = shape[:-2] - 2.0 * shape[1:-1] + shape[2:]
    best = None
    has_gap = bool(np.any(chemistry.gap))
    for gap in (True, False) if has_gap else (False,):
        target = voltage - gaps if gap else voltage
        for weight in SMOOTHNESS:
            error = _cross_validated(design, target, fold, weight * scale * smooth, weight * scale * smooth_target)
            if best is None or error < best[0]:
                best = (error, gap, weight)
    curve_cv, gap, weight = best
    if not curve_cv < LEARN_GAIN * preset_cv:
        return None
    # the time constants (and the later logs' starting SOC) again, with the curve beside the resistances
    from scipy.optimize import least_squares
    p = chemistry.params
    scales = [chemistry.arrhenius(temperature) for temperature in temperatures]
    arrays = [piece[0] for piece in electrical.pieces]

    def solve(z):
        cell_capacity = math.exp(z[2]) / electrical.cells_parallel
        soc0 = list(z[3:])
        rows, targets, pieces = [], [], []
        socs = []
        for k, a in enumerate(arrays):
            soc = state_of_charge(a, cell_capacity, soc0[k], p.coulombic_efficiency)
            socs.append(soc[masks[k]])
        grid = np.linspace(min(float(np.min(s)) for s in socs), max(float(np.max(s)) for s in socs), count)
        if grid[-1] - grid[0] < 1e-6:
            grid = knots
        grid_shape = np.interp(grid, chemistry.soc_points, chemistry.ocv)
        for k, a in enumerate(arrays):
            m = masks[k]
            soc = state_of_charge(a, cell_capacity, soc0[k], p.coulombic_efficiency)
            x0, x1, xf = regressors(a, soc, scales[k], chemistry, math.exp(z[0]), math.exp(z[1]),
                                    electrical.use_tables)
            pieces.append((a, soc, x0, x1, xf))
            rows.append(np.column_stack([hat_basis(soc[m], grid), x0[m], x1[m], xf[m]]))
            shift = np.interp(soc, chemistry.soc_points, chemistry.gap) * a.weight if gap else 0.0
            targets.append((a.cell_voltage - shift)[m])
        smooth_rows = weight * scale * smooth
        smooth_values = weight * scale * (grid_shape[:-2] - 2.0 * grid_shape[1:-1] + grid_shape[2:])
        return grid, np.vstack(rows + [smooth_rows]), np.concatenate(targets + [smooth_values]), len(
            np.concatenate(targets))

    def residuals(z):
        _, matrix, target, n = solve(z)
        values = np.linalg.lstsq(matrix, target, rcond=None)[0]
        return (target - matrix @ values)[:n]

    # the capacity and every log's starting SOC searched again: the curve's smoothness (its bends held near the
    # preset's) and the logs' overlap place them
    # (or both from the logged percentage, where it moves: a shape-free reading of the charge)
    gauge = _percentage_capacity(logs, masks)
    capacity, soc0 = (math.log(gauge[0]), gauge[1]) if gauge else (math.log(electrical.capacity_ah), electrical.soc0)
    z0 = [math.log(electrical.tau1_s), math.log(electrical.tau_fast_s), capacity] + list(soc0)
    spread = math.log(1.02 if gauge else 3.0)
    low_bounds = [math.log(TAU1_BOUNDS[0]), math.log(TAU_FAST_BOUNDS[0]), capacity - spread] + [
        max(0.0, s - 0.02) if gauge else 0.0 for s in soc0]
    high_bounds = [math.log(TAU1_BOUNDS[1]), math.log(TAU_FAST_BOUNDS[1]), capacity + spread] + [
        min(1.0, s + 0.02) if gauge else 1.0 for s in soc0]
    z0 = np.clip(z0, np.asarray(low_bounds) + 1e-9, np.asarray(high_bounds) - 1e-9)
    solution = least_squares(residuals, z0, bounds=(low_bounds, high_bounds), x_scale='jac', diff_step=1e-4,
                             max_nfev=60)
    for weight in [w for w in SMOOTHNESS if w >= weight]:   # the smoothest needed for an increasing curve
        grid, matrix, target, n = solve(solution.x)
        solved = np.linalg.lstsq(matrix, target, rcond=None)[0]
        if np.all(np.diff(solved[:count]) > 0):
            break
    else:
        return None
    names = ['knot%d' % j for j in range(count)] + ['r0_ohm', 'r1_ohm', 'r_fast_ohm']
    values, sigmas, residual = _non_negative_lstsq(matrix, target, ['offset'] * count + names[count:])
    resistances = [max(values[name], 0.0) for name in names[count:]]
    curve = solved[:count] if all(solved[count:] >= 0) else None
    if curve is None:   # the curve beside the non-negative resistances
        fixed = matrix[:, count:] @ np.asarray(resistances)
        curve = np.linalg.lstsq(matrix[:, :count], target - fixed, rcond=None)[0]
    fit_residual = (target - matrix @ np.concatenate([curve, resistances]))[:n]
    return {'knots': grid, 'values': _increasing(curve), 'rmse_v': float(np.sqrt(np.mean(fit_residual ** 2))),
            'resistances': dict(zip(names[count:], resistances)),
            'sigmas': {name: sigmas.get(name) for name in names[count:]}, 'gap': gap, 'smoothness': weight,
            'cv': (preset_cv, curve_cv), 'tau1_s': math.exp(solution.x[0]), 'tau_fast_s': math.exp(solution.x[1]),
            'soc0': [float(v) for v in solution.x[3:]], 'capacity_ah': math.exp(solution.x[2])}


def _percentage_capacity(logs, masks):
    """(pack capacity, starting SOC per log) from the logged percentage against the counted charge, where
    every log has it and it moves by PERCENTAGE_SPAN in all; else None."""
    rows, targets = [], []
    for index, (log, mask) in enumerate(zip(logs, masks)):
        if log.percentage is None:
            return None
        charge = np.concatenate([[0.0], np.cumsum(log.current_a[1:] * np.diff(log.time_s))]) / 3600.0
        use = mask & np.isfinite(log.percentage)
        if use.sum() < 10:
            return None
        row = np.zeros((use.sum(), len(logs) + 1))
        row[:, index] = 1.0
        row[:, -1] = charge[use]
        rows.append(row)
        targets.append(log.percentage[use])
    target = np.concatenate(targets)
    if np.ptp(target) < PERCENTAGE_SPAN:
        return None
    values = np.linalg.lstsq(np.vstack(rows), target, rcond=None)[0]
    if not values[-1] > 0 or not all(0.0 <= v <= 1.0 for v in values[:-1]):
        return None
    return 1.0 / values[-1], [float(v) for v in values[:-1]]


def _cross_validated(design, target, fold, smooth, smooth_target):
    """The RMSE of least squares predicting each fold from the others (a smoothness penalty beside)."""
    folds = int(fold.max()) + 1
    grams, moments, squares = [], [], []
    for f in range(folds):
        rows = fold == f
        grams.append(design[rows].T @ design[rows])
        moments.append(design[rows].T @ target[rows])
        squares.append(float(target[rows] @ target[rows]))
    gram, moment = sum(grams), sum(moments)
    if smooth is not None:
        gram_smooth, moment_smooth = smooth.T @ smooth, smooth.T @ smooth_target
    total = 0.0
    for f in range(folds):
        a, b = gram - grams[f], moment - moments[f]
        if smooth is not None:
            a, b = a + gram_smooth, b + moment_smooth
        values = np.linalg.lstsq(a, b, rcond=None)[0]
        total += max(squares[f] - 2.0 * values @ moments[f] + values @ grams[f] @ values, 0.0)
    return math.sqrt(total / len(target))


def _increasing(values, step=1e-4):
    """The closest strictly increasing sequence in the simple sense: each at least ``step`` above the last."""
    values = np.array(values, dtype=float)
    for k in range(1, len(values)):
        values[k] = max(values[k], values[k - 1] + step)
    return values


def _electrical_values(electrical, curve, chemistry, cells_series, cells_parallel, has_rest, fitted, kept, warnings):
    p = chemistry.params
    changes = {}
    capacity = electrical.capacity_ah
    cell_capacity = capacity / cells_parallel
    changes['cell_capacity_ah'] = round(cell_capacity, 4)
    fitted['cells_parallel'] = Fitted(cells_parallel, 'the pack capacity %.3g Ah over the preset cell\'s %.3g Ah '
                                      '(only the pack figures are identified: parallel count x cell)'
                                      % (capacity, p.cell_capacity_ah))
    fitted['cell_capacity_ah'] = Fitted(changes['cell_capacity_ah'], 'coulomb counting against the OCV curve '
                                        '(pack %.4g Ah)' % capacity,
                                        electrical.uncertainty['capacity_ah'] / cells_parallel)
    coefficients = dict((k, v) for k, v in electrical.coefficients.items())
    source = 'current steps and relaxations'
    if curve is not None:
        for name, value in curve['resistances'].items():
            coefficients[name] = (value, curve['sigmas'].get(name))
        source += ', beside the learned OCV curve'
    minimum = {'r0_ohm': 1e-5}
    for name in ('r0_ohm', 'r1_ohm', 'r_fast_ohm'):
        value, sigma = coefficients[name]
        value = max(value, minimum.get(name, 0.0))
        changes[name] = float('%.5g' % value)
        fitted[name] = Fitted(changes[name], source + ' (per cell)', sigma)
    for name in ('tau1_s', 'tau_fast_s'):
        changes[name] = float('%.4g' % getattr(electrical, name))
        fitted[name] = Fitted(changes[name], 'the relaxations\' time constant', electrical.uncertainty[name])
    if not electrical.use_tables and chemistry.table_soc is not None:
        changes.update(resistance_soc=(), r0_soc_factor=(), r1_soc_factor=(), r_fast_soc_factor=())
        fitted['resistance_soc'] = Fitted((), 'the preset\'s SOC factor tables fitted worse than none')
    soc = np.asarray(chemistry.soc_points)
    if curve is None:
        offset, sigma = coefficients['offset']
        if not has_rest:
            kept['ocv_voltage_v'] = 'the preset\'s OCV without an offset: no rest in the logs (>= %.0f s at no ' \
                                    'current) to read it from' % REST_S
            volts = chemistry.ocv.copy()
        else:
            volts = chemistry.ocv + offset
            fitted['ocv_voltage_v'] = Fitted('preset shape %+.4f V' % offset, 'the rests\' voltages', sigma)
    else:
        knots, values = curve['knots'], curve['values']
        below, above = soc < knots[0], soc > knots[-1]
        # outside the covered range the preset's shape, its departure at the ends fading to none at 0 and 1
        start = values[0] - np.interp(knots[0], soc, chemistry.ocv)
        end = values[-1] - np.interp(knots[-1], soc, chemistry.ocv)
        volts_below = chemistry.ocv[below] + start * soc[below] / knots[0]
        volts_above = chemistry.ocv[above] + end * (1.0 - soc[above]) / max(1.0 - knots[-1], 1e-9)
        soc = np.concatenate([soc[below], knots, soc[above]])
        volts = np.concatenate([volts_below, values, volts_above])
        preset_cv, curve_cv = curve['cv']
        fitted['ocv_voltage_v'] = Fitted(
            'learned at %d points over SOC %.2f-%.2f' % (len(knots), knots[0], knots[-1]),
            'the logs\' voltages: blocks of the fitted part held out in turn were predicted to %.1f mV per cell '
            'by the learned curve (smoothness %g%s), %.1f mV by the preset\'s shape; fitted %.1f mV; outside '
            'the covered range the preset\'s shape, joined' % (
                1000 * curve_cv, curve['smoothness'], ', the preset\'s hysteresis' if curve['gap'] else
                ', no hysteresis', 1000 * preset_cv, 1000 * curve['rmse_v']))
        warnings.append('the OCV curve is learned over SOC %.2f-%.2f only: outside it the %s shape is a guess, '
                        'and so is the capacity (the SOC scale rests on that shape)' % (knots[0], knots[-1], p.name))
    volts = _increasing(volts)
    changes['ocv_soc'] = tuple(float('%.5g' % s) for s in soc)
    changes['ocv_voltage_v'] = tuple(float('%.5f' % v) for v in volts)
    if curve is not None and not curve['gap']:
        changes['ocv_charge_voltage_v'] = ()   # the learned curve fits best without the preset's hysteresis
    elif p.ocv_charge_voltage_v:
        gap = np.interp(soc, chemistry.soc_points, chemistry.gap)
        changes['ocv_charge_voltage_v'] = tuple(float('%.5f' % v) for v in _increasing(np.maximum(volts + gap, volts)))
    # the charge voltage and the cut-off within the table
    changes['cell_charge_voltage_v'] = float('%.5f' % min(p.cell_charge_voltage_v, volts[-1]))
    changes['cell_cutoff_voltage_v'] = float('%.5f' % max(p.cell_cutoff_voltage_v, volts[0]))
    if changes['cell_cutoff_voltage_v'] >= changes['cell_charge_voltage_v']:
        raise FitError('the fitted OCV curve leaves no room between the cut-off and the charge voltage')
    return changes


def _fit_loads(logs, masks, cells_series, chemistry_params, fitted, kept):
    """Idle current / power and the motion coefficients from the discharge samples:
    -I = I_idle + (P_idle + drive |v| + turn |w|) / V (the model's load equation)."""
    changes = {}
    has_motion = any(log.speed_mean is not None for log in logs)
    best = None
    for which in (('speed_mean', 'turn_mean'), ('speed_now', 'turn_now')) if has_motion else ((None, None),):
        columns, target = [[], [], [], []], []
        for log, mask in zip(logs, masks):
            use = mask & (log.current_a < 0)
            use[0] = False
            volts = log.voltage_v[use]
            columns[0].append(np.ones(use.sum()))
            columns[1].append(1.0 / volts)
            speed = getattr(log, which[0]) if which[0] and getattr(log, which[0]) is not None else np.zeros(len(use))
            turn = getattr(log, which[1]) if which[1] and getattr(log, which[1]) is not None else np.zeros(len(use))
            columns[2].append(speed[use] / volts)
            columns[3].append(turn[use] / volts)
            target.append(-log.current_a[use])
        design = np.column_stack([np.concatenate(c) for c in columns])
        target = np.concatenate(target)
        if len(target) < 10:
            break
        usable = [j for j in range(4) if np.ptp(design[:, j]) > 0 or j < 2]
        for size in range(1, len(usable) + 1):
            for subset in itertools.combinations(usable, size):
                values, *_ = np.linalg.lstsq(design[:, subset], target, rcond=None)
                if (values < 0).any():
                    continue
                residual = target - design[:, subset] @ values
                score = float(residual @ residual) * (1.0 + 2.0 * size / len(target))
                if best is None or score < best[0]:
                    best = (score, subset, values, design, target, residual)
    if best is None:
        kept['load_current_a'] = 'no discharge samples to read the idle load from'
        return changes
    _, subset, values, design, target, residual = best
    dof = max(1, len(target) - len(subset))
    covariance = np.linalg.pinv(design[:, subset].T @ design[:, subset]) * float(residual @ residual) / dof
    sigma = np.sqrt(np.maximum(np.diag(covariance), 0.0))
    found = {j: (float(values[k]), float(sigma[k])) for k, j in enumerate(subset)}
    names = ('load_current_a', 'load_power_w', 'drive_power_w_per_mps', 'turn_power_w_per_radps')
    sources = ('the battery current with the robot on', 'the battery power with the robot on',
               'battery power against the commanded speed', 'battery power against the commanded turn rate')
    for j, name in enumerate(names):
        if j in found:
            changes[name] = float('%.4g' % found[j][0])
            fitted[name] = Fitted(changes[name], sources[j], found[j][1])
        elif j < 2:
            changes[name] = 0.0
            fitted[name] = Fitted(0.0, 'the idle load is explained by %s' % names[1 - j])
        elif not has_motion:
            kept[name] = 'no motion topic (cmd_vel / odometry) or linear_x / angular_z columns in the logs'
        else:
            changes[name] = 0.0
            fitted[name] = Fitted(0.0, 'the battery power does not grow with it')
    return changes


def _fit_charger(logs, masks, cells_series, cells_parallel, chemistry_params, changes, fitted, kept):
    """The charger from every charge in the logs (held-out parts too: the replayed voltage takes the logged
    current, so the charger's values do not enter the held-out figure)."""
    p = chemistry_params
    masks = [np.ones(len(log.time_s), dtype=bool) for log in logs]
    # a charge: more than C/40 (a sensor's noise at rest is not one)
    threshold = max(0.05, changes['cell_capacity_ah'] * cells_parallel / 40.0)
    # a charge lasts (a vehicle's regeneration, pulses of charge current while it drives, is not one)
    masks = [_lasting(log.time_s, log.current_a > threshold, CHARGE_MIN_S) for log in logs]
    charging = [log.current_a[mask & (log.current_a > threshold)] for log, mask in zip(logs, masks)]
    currents = np.concatenate(charging)
    result = {}
    if len(currents) < 10:
        kept['charge_current_a'] = 'no charge in the logs: the preset\'s C-rate at the fitted capacity'
        result['charge_current_a'] = float('%.4g' % (p.charge_current_a / p.design_capacity_ah
                                                     * changes['cell_capacity_ah'] * cells_parallel))
        return result
    current = float(np.percentile(currents, 90))
    result['charge_current_a'] = float('%.4g' % current)
    fitted['charge_current_a'] = Fitted(result['charge_current_a'], 'the charge\'s constant current (90th '
                                        'percentile of %d charging samples)' % len(currents),
                                        float(np.std(currents[currents > 0.8 * current])))
    top = max(float(np.max(log.voltage_v[mask & (log.current_a > threshold)]) if (mask & (log.current_a > threshold)).any()
                    else 0.0) for log, mask in zip(logs, masks)) / cells_series
    tapering = np.concatenate([c[c < 0.7 * current] for c in charging])
    if len(tapering) >= 5 and top > 0:
        limit = math.floor(1e4 * min(top, changes['ocv_voltage_v'][-1])) / 1e4   # within the OCV table
        if limit > changes['cell_cutoff_voltage_v']:
            result['cell_charge_voltage_v'] = limit
            fitted['cell_charge_voltage_v'] = Fitted(result['cell_charge_voltage_v'], 'the charge\'s constant '
                                                     'voltage (its highest cell voltage, %d samples tapering)'
                                                     % len(tapering))
        end = float(np.min(tapering))
        if 0 < end < current:
            result['termination_current_a'] = float('%.4g' % end)
            fitted['termination_current_a'] = Fitted(result['termination_current_a'], 'the end of the taper')
    else:
        kept['cell_charge_voltage_v'] = 'the charges in the logs do not reach constant voltage (no taper)'
    max_charge = p.cell_max_charge_current_a * cells_parallel
    if result['charge_current_a'] > max_charge:
        result['cell_max_charge_current_a'] = float('%.4g' % (1.2 * result['charge_current_a'] / cells_parallel))
    return result


def _lasting(time_s, flags, seconds):
    """``flags`` where they hold for at least ``seconds`` on end."""
    out = np.zeros(len(flags), dtype=bool)
    edges = np.flatnonzero(np.diff(np.concatenate([[0], flags.astype(int), [0]])))
    for start, stop in zip(edges[::2], edges[1::2]):
        if time_s[stop - 1] - time_s[start] >= seconds:
            out[start:stop] = True
    return out


def _limits(logs, cells_series, cells_parallel, chemistry_params, changes, fitted):
    """The datasheet currents raised to what the logs show, so the model never cuts the logged load off."""
    p = chemistry_params
    result = {}
    discharge = max(float(-np.min(log.current_a)) for log in logs) / cells_parallel
    if discharge * 1.2 > p.cell_max_discharge_current_a:
        result['cell_max_discharge_current_a'] = float('%.4g' % (1.2 * discharge))
        fitted['cell_max_discharge_current_a'] = Fitted(result['cell_max_discharge_current_a'],
                                                        'the logs\' largest discharge current + 20 %')
    charge = max(float(np.max(log.current_a)) for log in logs) / cells_parallel
    limit = max(charge * 1.2, changes.get('cell_max_charge_current_a', p.cell_max_charge_current_a),
                changes['charge_current_a'] / cells_parallel * 1.01)
    if limit > p.cell_max_charge_current_a:
        result['cell_max_charge_current_a'] = float('%.4g' % limit)
        fitted['cell_max_charge_current_a'] = Fitted(result['cell_max_charge_current_a'],
                                                     'the logs\' largest charge current + 20 %')
    load = changes.get('load_current_a', p.load_current_a)
    if load > result.get('cell_max_discharge_current_a', p.cell_max_discharge_current_a) * cells_parallel:
        result['cell_max_discharge_current_a'] = float('%.4g' % (1.2 * load / cells_parallel))
    return result


def _cell_heat(log, cells_parallel, electrical, scale):
    i = log.current_a / cells_parallel
    r = sum(electrical.coefficients[name][0] for name in ('r0_ohm', 'r1_ohm', 'r_fast_ohm'))
    return i * i * r * scale


def _fit_thermal(logs, masks, chemistry, cells_parallel, electrical, fitted, kept):
    """Ambient, heat capacity and transfer from the logged temperature (when it moves)."""
    from scipy.optimize import least_squares
    p = chemistry.params
    logged = [log for log in logs if log.temperature_c is not None]
    changes = {}
    heat = {'ambient': p.ambient_temperature_c, 'capacity': p.cell_heat_capacity_j_per_k,
            'transfer': p.cell_heat_transfer_w_per_k, 'changes': changes}
    if not logged:
        for name in ('ambient_temperature_c', 'cell_heat_capacity_j_per_k', 'cell_heat_transfer_w_per_k'):
            kept[name] = 'no temperature in the logs'
        return heat
    first = float(logged[0].temperature_c[0])
    changes['initial_temperature_c'] = float('%.3g' % first)
    fitted['initial_temperature_c'] = Fitted(changes['initial_temperature_c'], 'the first log\'s first temperature')
    spread = max(float(np.ptp(log.temperature_c)) for log in logged)
    if spread < 1.0:
        changes['ambient_temperature_c'] = float('%.3g' % np.median(np.concatenate([log.temperature_c for log in logged])))
        fitted['ambient_temperature_c'] = Fitted(changes['ambient_temperature_c'], 'the logged temperature '
                                                 '(it moves less than 1 K: the heat figures kept)')
        heat['ambient'] = changes['ambient_temperature_c']
        return heat
    pairs = [(log, mask, log_arrays(log, chemistry, 1, cells_parallel)) for log, mask in zip(logs, masks)
             if log.temperature_c is not None]

    def residuals(z):
        out = []
        for log, mask, arrays in pairs:
            cell_heat = _cell_heat(log, cells_parallel, electrical, chemistry.arrhenius(log.temperature_c))
            model = thermal(arrays, cell_heat, z[0], float(log.temperature_c[0]), math.exp(z[1]), math.exp(z[2]))
            out.append((model - log.temperature_c)[mask])
        return np.concatenate(out)
    z0 = [min(first, float(np.min(logged[0].temperature_c))), math.log(p.cell_heat_capacity_j_per_k),
          math.log(p.cell_heat_transfer_w_per_k)]
    solution = least_squares(residuals, z0, bounds=([-40, math.log(0.1), math.log(1e-4)], [90, math.log(1e6), math.log(1e3)]),
                             x_scale='jac', max_nfev=100)
    rmse = float(np.sqrt(np.mean(solution.fun ** 2)))
    sigmas = _jacobian_sigmas(solution, rmse)
    heat.update(ambient=float(solution.x[0]), capacity=math.exp(solution.x[1]), transfer=math.exp(solution.x[2]))
    for name, value, sigma in (('ambient_temperature_c', heat['ambient'], sigmas[0]),
                               ('cell_heat_capacity_j_per_k', heat['capacity'], heat['capacity'] * sigmas[1]),
                               ('cell_heat_transfer_w_per_k', heat['transfer'], heat['transfer'] * sigmas[2])):
        changes[name] = float('%.4g' % value)
        fitted[name] = Fitted(changes[name], 'the logged temperature under the fitted heat (RMSE %.2f K)' % rmse,
                              float(sigma))
    heat['ambient'] = changes['ambient_temperature_c']
    if not -60 <= changes['ambient_temperature_c'] <= 100:
        raise FitError('the logged temperature gives an ambient of %g degC: outside [-60, 100]'
                       % changes['ambient_temperature_c'])
    return heat


def _model_temperature(log, chemistry, cells_parallel, electrical, heat):
    """The temperature the model will have (its thermal mass from the first logged temperature)."""
    arrays = log_arrays(log, chemistry, 1, cells_parallel)
    start = float(log.temperature_c[0]) if log.temperature_c is not None else heat['ambient']
    if log.temperature_c is None and 'initial_temperature_c' in heat['changes']:
        start = heat['changes']['initial_temperature_c']
    temperature = np.full(len(log.time_s), start)
    for _ in range(2):
        cell_heat = _cell_heat(log, cells_parallel, electrical, chemistry.arrhenius(temperature))
        temperature = thermal(arrays, cell_heat, heat['ambient'], start, heat['capacity'], heat['transfer'])
    return temperature


def rmse(values):
    values = np.asarray(values)
    return float(np.sqrt(np.mean(values ** 2))) if len(values) else math.nan

