"""The electrical fit (no ROS): the capacity, starting SOCs and time constants searched, the OCV offset and
resistances solved by least squares; and the config values it gives (capacity, resistances, OCV table)."""
import math
from dataclasses import dataclass

import numpy as np

from battery_simulator.core.fit import FitError, Fitted
from battery_simulator.core.fit.circuit import log_arrays, rc_filter, regressors, state_of_charge
from battery_simulator.core.fit.known import KNOWN_SPREAD, REST_S, Known
from battery_simulator.core.parameter_rules import MAX_CELLS

#: bounds of the searched time constants, s
TAU1_BOUNDS, TAU_FAST_BOUNDS = (60.0, 20000.0), (2.0, 200.0)
#: an LFP slow pair at its bound gives way to one the fitted part can time where that fits within this factor
SLOW_PAIR_TIE = 1.05
#: the surface SOC's lag (surface_soc_lag_s, tau_surface_s): where the search starts and its bounds, s
SURFACE_LAG_START, SURFACE_LAG_BOUNDS = (80.0, 300.0), ((1.0, 2000.0), (10.0, 5000.0))


def parallel_count(capacity_ah, cell_capacity_ah):
    """The parallel count of a pack of ``capacity_ah`` of the preset's cells (at most MAX_CELLS: then the
    cells are larger)."""
    return min(MAX_CELLS, max(1, int(round(capacity_ah / cell_capacity_ah))))


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
    surface_soc_lag_s: float = 0.0  # 0: none (searched only with search_lag)
    tau_surface_s: float = None


def fit_electrical(logs, masks, chemistry, cells_series, cells_parallel, temperatures, has_rest, start,
                    max_evaluations=200, known=None, search_lag=False):
    """The capacity, starting SOCs and time constants searched, the OCV offset and resistances solved; where
    no log's current steps (steady_current) the resistances and time constants are the preset's. With
    ``search_lag`` the surface SOC's lag (surface_soc_lag_s, tau_surface_s: the OCV read at the bulk SOC less
    a first-order lag of the current) is searched too, and a cut-off's rest (known.empty_rest_at) pins the
    capacity with it: the bulk SOC at the rest's end is its voltage's SOC plus the lag left there."""
    from scipy.optimize import least_squares
    p = chemistry.params
    steady = steady_current(logs)
    arrays = [log_arrays(log, chemistry, cells_series, cells_parallel) for log in logs]
    scales = [chemistry.arrhenius(temperature) for temperature in temperatures]
    if start is None:
        soc0 = [_soc_guess(chemistry, a.cell_voltage[0]) for a in arrays]
        capacity = _capacity_guess(logs, arrays, chemistry, soc0)
        z0 = [math.log(capacity)] + soc0 + [math.log(p.tau1_s), math.log(p.tau_fast_s)]
    else:
        z0 = [math.log(start.capacity_ah)] + list(start.soc0) + [math.log(start.tau1_s), math.log(start.tau_fast_s)]
    n = len(logs)
    known = known or Known()
    slowest = tau1_bounds(logs, masks)
    low = [z0[0] - math.log(20.0)] + [0.0] * n + [math.log(slowest[0]), math.log(TAU_FAST_BOUNDS[0])]
    high = [z0[0] + math.log(20.0)] + [1.0] * n + [math.log(slowest[1]), math.log(TAU_FAST_BOUNDS[1])]
    lag_at = n + 1   # z[lag_at], z[lag_at + 1]: log surface_soc_lag_s, log tau_surface_s (with search_lag)
    if search_lag:
        begin = ((start.surface_soc_lag_s, start.tau_surface_s) if start is not None and start.surface_soc_lag_s
                 else SURFACE_LAG_START)
        z0[lag_at:lag_at] = [math.log(v) for v in begin]
        low[lag_at:lag_at] = [math.log(b[0]) for b in SURFACE_LAG_BOUNDS]
        high[lag_at:lag_at] = [math.log(b[1]) for b in SURFACE_LAG_BOUNDS]
    if known.capacity_ah is not None:   # the capacity (and the starting SOCs) the logs fix
        z0[0] = math.log(known.capacity_ah)
        low[0], high[0] = z0[0] - KNOWN_SPREAD, z0[0] + KNOWN_SPREAD
    for k in range(n):
        if known.soc0 is not None:
            z0[1 + k] = known.soc0[k]
            low[1 + k], high[1 + k] = max(0.0, known.soc0[k] - KNOWN_SPREAD), min(1.0, known.soc0[k] + KNOWN_SPREAD)
    if steady:   # the time constants: the preset's
        for j in (-2, -1):
            low[j], high[j] = z0[j] - 1e-6, z0[j] + 1e-6
    z0 = np.clip(z0, np.asarray(low) + 1e-9, np.asarray(high) - 1e-9)
    counted = [np.cumsum(np.where(a.cell_current > 0, p.coulombic_efficiency * a.cell_current, a.cell_current)
                         * a.dt) / 3600.0 * cells_parallel for a in arrays]   # pack Ah

    def lag(z):
        """(surface_soc_lag_s, tau_surface_s), (0, None) without search_lag."""
        return (math.exp(z[lag_at]), math.exp(z[lag_at + 1])) if search_lag else (0.0, None)

    def capacity_of(z):
        """The pack capacity: searched; pinned by a cut-off's rest, that pin moved by the lag left at its end."""
        lag_s, tau = lag(z)
        if not lag_s or known.empty_rest_at is None or known.capacity_ah is None:
            return math.exp(z[0])
        k, end = known.empty_rest_at
        a = arrays[k]
        left_a = rc_filter(-a.cell_current[:end + 1], np.exp(-a.dt[:end + 1] / tau))[-1] * cells_parallel
        return float(math.exp(z[0]) * (1.0 + lag_s * left_a / 3600.0 / (1.0 - known.cutoff_soc) / known.capacity_ah))

    def surface(a, soc, capacity, z):
        """The SOC the OCV is read at: the bulk one less the lag (core/battery_model.py's surface_soc)."""
        lag_s, tau = lag(z)
        if not lag_s:
            return soc
        return soc - lag_s / (capacity / cells_parallel * 3600.0) * rc_filter(-a.cell_current, np.exp(-a.dt / tau))

    def starts(z):
        """Each log's starting SOC: searched, or 1 at a full charge's end."""
        capacity = capacity_of(z)
        out = []
        for k in range(n):
            pin = known.start_pin(k)
            if pin is None:
                out.append(float(z[1 + k]))
            else:   # SOC 1 at a full charge's end, or SOC 0 at a cut-off
                out.append(min(1.0, max(0.0, (pin[0] == 'full') - counted[k][pin[1]] / capacity)))
        return out

    def solve(z, use_tables):
        capacity = capacity_of(z)
        tau1, tau_fast = math.exp(z[-2]), math.exp(z[-1])
        pieces, rows, targets = [], [], []
        soc0 = starts(z)
        for k, a in enumerate(arrays):
            soc = state_of_charge(a, capacity / cells_parallel, soc0[k], p.coulombic_efficiency)
            ocv = chemistry.ocv_at(surface(a, soc, capacity, z), a.weight)
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
        if steady:   # the preset's resistances: a steady current cannot tell them from the OCV
            preset_r = np.array([p.r0_ohm, p.r1_ohm, p.r_fast_ohm])
            target = target - design[:, -3:] @ preset_r
            values, sigmas, residual = non_negative_lstsq(design[:, :-3], target, names[:-3])
            values.update(zip(names[-3:], preset_r.tolist()))
            return pieces, values, sigmas, residual
        values, sigmas, residual = non_negative_lstsq(design, target, names)
        return pieces, values, sigmas, residual

    def residuals(z, use_tables):
        return solve(z, use_tables)[3]

    results = []
    for use_tables in (True, False) if chemistry.table_soc is not None else (False,):
        solution = least_squares(residuals, z0, bounds=(low, high), args=(use_tables,), x_scale='jac',
                                 diff_step=1e-4, max_nfev=max_evaluations)
        pieces, values, sigmas, residual = solve(solution.x, use_tables)
        rmse = float(np.sqrt(np.mean(residual ** 2)))
        if p.chemistry == 'lfp' and not steady and solution.x[-2] >= high[-2] - 0.01:
            # a slow pair at the search's bound is an integrator of the charge over the fitted part: it stands in
            # for the flat OCV's slope and an offset (the A123 US06 log: R1 0.56 ohm, tau1 20000 s, the OCV
            # 59 mV down, 33.3 mV per cell fitted, held out 440 mV). A pair the log can time (at most a
            # quarter of the fitted span) taken where it fits within SLOW_PAIR_TIE (34.2 mV: held out 18 mV)
            quarter = fitted_span_s(logs, masks) / 4.0
            capped = list(high)
            capped[-2] = max(low[-2] + 1e-6, math.log(max(TAU1_BOUNDS[0], min(TAU1_BOUNDS[1], quarter))))
            start = np.clip(z0, np.asarray(low) + 1e-9, np.asarray(capped) - 1e-9)
            timed = least_squares(residuals, start, bounds=(low, capped), args=(use_tables,), x_scale='jac',
                                  diff_step=1e-4, max_nfev=max_evaluations)
            timed_fit = solve(timed.x, use_tables)
            timed_rmse = float(np.sqrt(np.mean(timed_fit[3] ** 2)))
            if timed_rmse <= SLOW_PAIR_TIE * rmse:
                solution, rmse = timed, timed_rmse
                pieces, values, sigmas, residual = timed_fit
        results.append((rmse, use_tables, solution, pieces, values, sigmas))
    # the preset's SOC tables only where they explain the log better (else the simpler circuit)
    rmse, use_tables, solution, pieces, values, sigmas = min(results, key=lambda r: r[0] * (1.0 + 0.02 * r[1]))
    best = dict(values)
    best.setdefault('offset', 0.0)
    uncertainty = jacobian_sigmas(solution, rmse)
    capacity = capacity_of(solution.x)
    lag_s, tau = lag(solution.x)
    sigmas_of = {'capacity_ah': capacity * uncertainty[0], 'tau1_s': math.exp(solution.x[-2]) * uncertainty[-2],
                 'tau_fast_s': math.exp(solution.x[-1]) * uncertainty[-1]}
    if search_lag:
        sigmas_of.update(surface_soc_lag_s=lag_s * uncertainty[lag_at], tau_surface_s=tau * uncertainty[lag_at + 1])
    return Electrical(capacity_ah=capacity, soc0=starts(solution.x),
                      tau1_s=math.exp(solution.x[-2]), tau_fast_s=math.exp(solution.x[-1]),
                      coefficients={k: (best[k], sigmas.get(k)) for k in best}, rmse_v=rmse, use_tables=use_tables,
                      uncertainty=sigmas_of, pieces=pieces, cells_series=cells_series, cells_parallel=cells_parallel,
                      surface_soc_lag_s=lag_s, tau_surface_s=tau)


def tau1_bounds(logs, masks):
    """(low, high) of the searched slow pair's time constant, s: TAU1_BOUNDS, the top no longer than the
    fitted part's longest log lasts. A pair slower than that is not timed by the log: it integrates the charge,
    standing in for the OCV's slope (BMW i3 A22: tau1 6537 +- 1800 s and R1 13 times the preset's over 1103 s
    fitted, held out 16.5 mV per cell; with tau1 at most the span, 3.2)."""
    return TAU1_BOUNDS[0], max(2.0 * TAU1_BOUNDS[0], min(TAU1_BOUNDS[1], fitted_span_s(logs, masks)))


def fitted_span_s(logs, masks):
    """How long the fitted part of the longest log lasts, s (the slowest pair the logs can time)."""
    return max(float(log.time_s[mask][-1] - log.time_s[mask][0]) for log, mask in zip(logs, masks) if mask.any())


def jacobian_sigmas(solution, rmse):
    jacobian = solution.jac
    try:
        covariance = np.linalg.pinv(jacobian.T @ jacobian) * rmse ** 2
        return np.sqrt(np.maximum(np.diag(covariance), 0.0))
    except np.linalg.LinAlgError:
        return np.full(len(solution.x), np.nan)


def steady_current(logs):
    """Whether no log's current steps (conventions' FitLog.steady_current: a constant-current test)."""
    return all(log.steady_current for log in logs)


def small_lstsq(design, target):
    """Least squares of a few columns against many rows: the normal equations of the columns scaled to unit
    norm (a tall matrix's SVD costs the search most of its time)."""
    norms = np.sqrt(np.einsum('ij,ij->j', design, design))
    norms = np.where(norms > 0, norms, 1.0)
    gram = (design.T @ design) / np.outer(norms, norms)
    return np.linalg.lstsq(gram, (design.T @ target) / norms, rcond=1e-12)[0] / norms


def non_negative_lstsq(design, target, names):
    """Least squares with the resistances >= 0 (the offset free): dropping a negative one at a time.
    Returns ({name: value}, {name: sigma}, residual)."""
    if not names:
        return {}, {}, target
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


def increasing(values, step=1e-4):
    """The closest strictly increasing sequence in the simple sense: each at least ``step`` above the last."""
    values = np.array(values, dtype=float)
    for k in range(1, len(values)):
        values[k] = max(values[k], values[k - 1] + step)
    return values


def electrical_values(electrical, curve, chemistry, cells_series, cells_parallel, has_rest, fitted, kept, warnings,
                      level_source='the rests\' voltages'):
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
        if name in kept:   # the preset's (kept says why)
            continue
        value, sigma = coefficients[name]
        value = max(value, minimum.get(name, 0.0))
        changes[name] = float('%.5g' % value)
        fitted[name] = Fitted(changes[name], source + ' (per cell)', sigma)
    for name in ('tau1_s', 'tau_fast_s'):
        if name in kept:
            continue
        changes[name] = float('%.4g' % getattr(electrical, name))
        fitted[name] = Fitted(changes[name], 'the relaxations\' time constant', electrical.uncertainty[name])
    if electrical.surface_soc_lag_s:
        for name, why in (('surface_soc_lag_s', 'the voltage near empty and the rest after a cut-off (the OCV read at '
                           'a surface SOC that trails the counted one by this many seconds of the current)'),
                          ('tau_surface_s', 'the time constant of that lag')):
            changes[name] = float('%.4g' % getattr(electrical, name))
            fitted[name] = Fitted(changes[name], why, electrical.uncertainty[name])
    if not electrical.use_tables and chemistry.table_soc is not None:
        changes.update(resistance_soc=(), r0_soc_factor=(), r1_soc_factor=(), r_fast_soc_factor=())
        fitted['resistance_soc'] = Fitted((), 'the preset\'s SOC factor tables fitted worse than none')
    soc = np.asarray(chemistry.soc_points)
    shift = 0.0   # the preset's shape moved by the offset: its charge voltage with it
    if curve is None:
        offset, sigma = coefficients['offset']
        if not has_rest:
            kept['ocv_voltage_v'] = 'the preset\'s OCV without an offset: no rest in the logs (>= %.0f s at no ' \
                                    'current) to read it from' % REST_S
            volts = chemistry.ocv.copy()
        else:
            volts, shift = chemistry.ocv + offset, offset
            fitted['ocv_voltage_v'] = Fitted('preset shape %+.4f V' % offset, level_source, sigma)
    else:
        knots, values = np.array(curve['knots'], dtype=float), curve['values']
        knots[0] = 0.0 if knots[0] < 1e-4 else knots[0]          # a knot at the table's own end is that end
        knots[-1] = 1.0 if knots[-1] > 1.0 - 1e-4 else knots[-1]
        below, above = soc < knots[0] - 1e-4, soc > knots[-1] + 1e-4   # no point twice where they meet
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
        if curve.get('coulombic_efficiency') is not None:
            changes['coulombic_efficiency'] = round(curve['coulombic_efficiency'], 4)
            fitted['coulombic_efficiency'] = Fitted(
                changes['coulombic_efficiency'], 'the charges\' voltages beside the discharges\' on the learned curve '
                '(the charge a charge takes per charge a discharge gives back: the cells\' and the current '
                'sensor\'s)')
    volts = increasing(volts)
    changes['ocv_soc'] = tuple(float('%.5g' % s) for s in soc)
    changes['ocv_voltage_v'] = tuple(float('%.5f' % v) for v in volts)
    if curve is not None and not curve['gap']:
        changes['ocv_charge_voltage_v'] = ()   # the learned curve fits best without the preset's hysteresis
    elif p.ocv_charge_voltage_v:
        gap = np.interp(soc, chemistry.soc_points, chemistry.gap)
        changes['ocv_charge_voltage_v'] = tuple(float('%.5f' % v) for v in increasing(np.maximum(volts + gap, volts)))
    # the charge voltage and the cut-off within the table
    changes['cell_charge_voltage_v'] = float('%.5f' % min(p.cell_charge_voltage_v + shift, volts[-1]))
    changes['cell_cutoff_voltage_v'] = float('%.5f' % max(p.cell_cutoff_voltage_v, volts[0]))
    if changes['cell_cutoff_voltage_v'] >= changes['cell_charge_voltage_v']:
        raise FitError('the fitted OCV curve leaves no room between the cut-off and the charge voltage')
    return changes
