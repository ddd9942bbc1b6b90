"""The fits (no ROS): what a robot's logs identify of its battery, the rest kept from the chemistry preset.

    fit(logs, chemistry) -> FitResult

Order: the series count (from the voltage range, each candidate fitted), the capacity and each log's
starting SOC with the OCV of the preset's shape (its offset where the log has a rest), the resistances
and RC pairs (least squares for given time constants, the constants searched), where that shape does not
fit and the logs cover enough charge the OCV curve itself over the covered range, the idle and motion
loads (battery current against cmd_vel), the charger (a charge's CC current and CV voltage) and the
heat (the logged temperature). Each value carries its source and a 1-sigma uncertainty from the fit.

This module runs them in that order and chooses between the results; each part is a module of its own:
known.py (what the logs fix), series.py, electrical.py, ocv_curve.py, loads_charger.py and heat.py.
"""
import math
from dataclasses import dataclass, replace

import numpy as np

from battery_simulator.core.fit import FitError, Fitted
from battery_simulator.core.fit.circuit import Chemistry
from battery_simulator.core.fit.electrical import (electrical_values, fit_electrical, increasing,
                                                    non_negative_lstsq, parallel_count, steady_current)
from battery_simulator.core.fit.heat import fit_thermal, model_temperature
from battery_simulator.core.fit.known import (check_capacity, check_units, cutoff_warning, fit_mask,
                                               interpolated, known_charge, log_has_rest, pinned_at_dynamic_cutoff,
                                               preset_temperature)
from battery_simulator.core.fit.loads_charger import current_limits, fit_charger, fit_loads
from battery_simulator.core.fit.ocv_curve import LEARN_MIN_SOC_SPAN, fitted_soc_range, learn_curve
from battery_simulator.core.fit.series import CHEMISTRY_CLEAR, LEVEL_NOISE_V, series_count
from battery_simulator.core.parameter_rules import ParameterError

#: the held-out part of each log (its last fraction), by default
DEFAULT_HOLDOUT = 0.25
#: the fitted part replayed to check a learned OCV curve: at most this many samples (a longer log thinned)
REPLAY_CHECK_SAMPLES = 20000
#: a stretched SOC scale of the preset's OCV (its slope within these bounds) is fitted on the first
#: REMAP_TRAIN of each fitted part and taken where it fits the fitted part REMAP_GAIN better and predicts the
#: rest of the fitted part better than the preset's own scale (where the fitted parts cover as much SOC as a
#: learned curve needs, LEARN_MIN_SOC_SPAN)
REMAP_GAIN, REMAP_SLOPE, REMAP_TRAIN = 0.85, (0.3, 3.0), 0.7
#: a stretched scale holds down to this SOC (the logged percentage's), below it it returns to the preset's SOC 0
REMAP_JOIN = 0.05
#: the config without hysteresis is taken where its replay of the fitted part is below this many times the
#: config's with the preset's hysteresis
VARIANT_GAIN = 0.8
#: the charge branch's gap above the discharge branch tried at these fractions of the preset's (0: none)
CHARGE_GAP_SCALES = (0.5, 0.0)


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
    left_out: list = None          # per log: samples of the fitted part left out (a filled gap: no measurement)


def fit(logs, chemistry_params, chemistry_name, cells_series=None, holdout=DEFAULT_HOLDOUT, progress=None,
        alternatives=()):
    """A FitResult for ``logs`` (FitLogs of one robot) over the chemistry preset's parameters; with
    ``alternatives`` ((name, params) of other chemistry presets) the chemistry is found from the logs too."""
    progress = progress or (lambda fraction, text: None)
    warnings = []
    splits = [fit_mask(log, holdout) for log in logs]   # the fitted part of each log (the rest held out)
    fitted, kept = {}, {}
    masks = []   # the samples fitted: the fitted part without a gap of the source filled by interpolation
    for log, split in zip(logs, splits):
        filled = split & interpolated(log)
        if filled.sum() and (split & ~filled).sum() >= 10:
            warnings.append('%s: %.0f s where the voltage and the current both run straight in time (a gap in the '
                            'source filled by interpolation: no measurement) left out of the fit' % (
                                log.name, float(np.sum(np.diff(log.time_s)[filled[1:]]))))
            split = split & ~filled
        masks.append(split)
    check_units(logs, masks)
    known = known_charge(logs, masks)
    # -- series count and chemistry
    progress(0.02, 'series count')
    candidates = [(chemistry_name, chemistry_params)] + list(alternatives)
    counts = sorted({log.cell_count for log in logs if log.cell_count})
    if cells_series is None and counts:
        cells_series, why = counts[-1], 'the logs\' BatteryState.cell_voltage (%d cells)' % counts[-1]
        if len(counts) > 1:
            warnings.append('the logs\' cell_voltage has %s entries: %d taken' % (
                ' or '.join(str(c) for c in counts), counts[-1]))
    else:
        why = 'given (--cells-series)' if cells_series else None
    cells_series, why, chemistry_name, chemistry_params, level_off = series_count(
        logs, masks, candidates, known, cells_series, why, progress, warnings)
    fitted['cells_series'] = Fitted(cells_series, why)
    known = pinned_at_dynamic_cutoff(known, chemistry_params, cells_series, fitted)
    if len(candidates) > 1:
        fitted['chemistry'] = Fitted(chemistry_params.chemistry, 'the %s preset\'s shape, taken among %s '
                                     '(the largest Li-ion cell a pack of known capacity holds first, another '
                                     'only where %.3g times better, and one of its chemistry only where the '
                                     'first\'s level is off by more than %.0f mV per cell)'
                                     % (chemistry_name, ', '.join(name for name, _ in candidates),
                                        1.0 / CHEMISTRY_CLEAR, 1000 * LEVEL_NOISE_V))
    rests = any(log_has_rest(log, mask) for log, mask in zip(logs, masks))
    # the OCV's level (an offset to the preset's shape) is read from a rest, or from a drive where the logged
    # percentage gives the SOC (the BMS pins the SOC, the current's steps the resistances). Where the count
    # taken is the best fit of the preset's level, that level fits already, and over a short drive an offset
    # and a slow RC pair trade: the offset is taken there only where its config replays the fitted part
    # clearly closer (BMW i3 A01: 4.0 mV per cell held out without it, 8.2 with it). Where the count is the
    # usual layout near the best fit, the preset's level is off by as much: the offset is read (A02 at 96
    # cells: 43.5 mV per cell held out without it, 5.7 with it)
    if rests or known.soc0 is None or steady_current(logs):
        levels = [rests]
    else:
        levels = [True] if level_off else [False, True]
    results = []
    for level in levels:
        results.append(_fit_at_count(logs, masks, splits, known, chemistry_params, chemistry_name, cells_series, level,
                                     'the rests\' voltages' if rests else 'the voltage at the SOC the logged '
                                     'percentage gives', dict(fitted), dict(kept), list(warnings), progress))
    if _lag_identifiable(logs, known, chemistry_params):
        results[0] = _with_surface_lag(results[0], logs, masks, splits, known, chemistry_params, chemistry_name,
                                       cells_series, levels[0], 'the rests\' voltages' if rests else 'the voltage '
                                       'at the SOC the logged percentage gives', fitted, kept, warnings, progress)
    score, chosen = results[0]
    if len(results) > 1:
        other = results[1][0]
        if other < VARIANT_GAIN * score:
            chosen = results[1][1]
        elif 'ocv_voltage_v' in chosen.kept:
            n = chosen.params.cells_series
            chosen.kept['ocv_voltage_v'] += ('; an offset read at the logged percentage replayed the fitted part to '
                                             '%.1f mV per cell, without it %.1f' % (1000 * other / n, 1000 * score / n))
    progress(1.0, 'done')
    return chosen


def _lag_identifiable(logs, known, chemistry_params):
    """Whether the fitted part can tell a surface SOC's lag (surface_soc_lag_s): an LFP cell (its OCV falls
    steeply only near empty) discharged to a cut-off with a rest after it (known.empty_rest_at)."""
    return chemistry_params.chemistry == 'lfp' and known.empty_rest_at is not None and not steady_current(logs)


def _with_surface_lag(plain, logs, masks, splits, known, chemistry_params, chemistry_name, cells_series, has_rest,
                      level_source, fitted, kept, warnings, progress):
    """(score, FitResult): ``plain`` or the fit with a surface SOC's lag searched, taken where its replay of the
    fitted part is clearly closer (VARIANT_GAIN). Near empty LFP's voltage depends on how the cell got there (the
    A123 cell gives 1.038 Ah from full to its 1C cut-off, 1.051 to FUDS's): the OCV read at a surface SOC that
    trails the counted one under current gives that, the charge counted exactly."""
    score, chosen = plain
    lagged_score, lagged = _fit_at_count(logs, masks, splits, known, chemistry_params, chemistry_name, cells_series,
                                         has_rest, level_source, dict(fitted), dict(kept), list(warnings), progress,
                                         search_lag=True)
    n = chosen.params.cells_series
    if lagged.params.surface_soc_lag_s and lagged_score < VARIANT_GAIN * score:
        lagged.fitted['surface_soc_lag_s'].source += '; the replay of the fitted part %.1f mV per cell with it, %.1f ' \
            'without' % (1000 * lagged_score / n, 1000 * score / n)
        if 'cutoff_soc' in lagged.fitted:   # (a Fitted the plain result shares: a new one)
            pinned = lagged.fitted['cutoff_soc']
            lagged.fitted['cutoff_soc'] = replace(pinned, source=pinned.source + '; with the surface SOC\'s lag left '
                                                  'at the rest\'s end (bulk above surface) %.4g Ah'
                                                  % lagged.params.design_capacity_ah)
        return lagged_score, lagged
    chosen.kept['surface_soc_lag_s'] = 'the replay of the fitted part %.1f mV per cell with a surface SOC\'s lag ' \
        'searched, %.1f without: none' % (1000 * lagged_score / n, 1000 * score / n)
    return score, chosen


def _fit_at_count(logs, masks, splits, known, chemistry_params, chemistry_name, cells_series, has_rest, level_source,
                  fitted, kept, warnings, progress, search_lag=False):
    """(replayed RMSE of the fitted part, FitResult) at the series count and chemistry found, the OCV's
    offset fitted where ``has_rest``."""
    chemistry = Chemistry(chemistry_params)
    # -- the electrical fit, with the model's temperature
    progress(0.25, 'capacity and resistances')
    temperatures = [preset_temperature(log, chemistry) for log in logs]
    electrical = fit_electrical(logs, masks, chemistry, cells_series, 1, temperatures, has_rest, None, known=known,
                                search_lag=search_lag)
    cells_parallel = parallel_count(electrical.capacity_ah, chemistry_params.cell_capacity_ah)
    heat_params = fit_thermal(logs, masks, chemistry, cells_parallel, electrical, fitted, kept, warnings)
    temperatures = [model_temperature(log, chemistry, cells_parallel, electrical, heat_params) for log in logs]
    progress(0.55, 'capacity and resistances (with the heat)')
    electrical = fit_electrical(logs, masks, chemistry, cells_series, cells_parallel, temperatures, has_rest,
                                 electrical, known=known, search_lag=search_lag)
    check_capacity(logs, masks, electrical.capacity_ah)
    if known.soc0 is not None and not steady_current(logs):   # the percentage fixes the SOC: the preset's shape
        # may sit on it stretched
        remapped = _remapped_chemistry(masks, chemistry, electrical, has_rest, fitted)
        if remapped is not None:
            chemistry = remapped
            electrical = fit_electrical(logs, masks, chemistry, cells_series, cells_parallel, temperatures,
                                         has_rest, electrical, known=known, search_lag=search_lag)
    progress(0.75, 'OCV curve')
    curve = None
    if steady_current(logs):
        for name in ('r0_ohm', 'r1_ohm', 'r_fast_ohm', 'tau1_s', 'tau_fast_s'):
            kept[name] = 'the current never steps (a constant-current test): the resistances cannot be told ' \
                         'from the OCV\'s level'
    else:
        curve = learn_curve(logs, masks, chemistry, temperatures, electrical, has_rest, known)
    plain = (electrical, heat_params)
    for rounds in range(2):
        if curve is None:
            break
        # its resistances and time constants, the heat they make, the temperature, and the curve again at it
        coefficients = dict(electrical.coefficients)
        coefficients.update((name, (value, curve['sigmas'].get(name))) for name, value in curve['resistances'].items())
        electrical = replace(electrical, tau1_s=curve['tau1_s'], tau_fast_s=curve['tau_fast_s'], soc0=curve['soc0'],
                             coefficients=coefficients, capacity_ah=curve['capacity_ah'])
        heat_params = fit_thermal(logs, masks, chemistry, cells_parallel, electrical, {}, {}, [])
        if rounds == 0 and any(log.temperature_c is not None for log in logs):
            temperatures = [model_temperature(log, chemistry, cells_parallel, electrical, heat_params) for log in logs]
            curve = learn_curve(logs, masks, chemistry, temperatures, electrical, has_rest, known) or curve
        else:
            break
    progress(0.85, 'loads and charger')
    loads = fit_loads(logs, masks, cells_series, chemistry_params, fitted, kept)
    choices = [(None, plain[0], plain[1])] + ([(curve, electrical, heat_params)] if curve is not None else [])
    built = []
    for index, (which, this_electrical, this_heat) in enumerate(choices):
        these_fitted, these_kept, these_warnings = dict(fitted), dict(kept), list(warnings)
        if this_heat is not plain[1]:   # the heat of the curve's resistances, said in this result
            fit_thermal(logs, masks, chemistry, cells_parallel, this_electrical, these_fitted, these_kept,
                         these_warnings)
        params = _assemble(logs, masks, this_electrical, which, this_heat, loads, chemistry, chemistry_name,
                           cells_series, cells_parallel, has_rest, these_fitted, these_kept, these_warnings,
                           level_source)
        result = FitResult(params=params, chemistry=chemistry_name, fitted=these_fitted, kept=these_kept,
                           warnings=these_warnings, logs=logs, initial_soc=list(this_electrical.soc0),
                           fit_masks=splits, left_out=[split & ~mask for split, mask in zip(splits, masks)])
        built.append((replayed_fit_rmse(result), index, result))
        progress(0.9 + 0.03 * index, 'the OCV curve checked by replay')
        if params.ocv_charge_voltage_v:
            # a sensor's noise at rest, replayed, walks the hysteresis state; and a charge branch read from a
            # charge's voltage holds the slow polarisation the RC pair models too (the A123 LFP cell: its
            # model 30-47 mV above the cell's 1C charge, at the charge voltage by 70 % SOC, so a replay's
            # charge stopped short there). The branch at a fraction of its gap, or none, taken only where the
            # replay of the fitted part is clearly closer (a tie says nothing of what the branch is worth)
            base = built[-1][0]
            for scale in CHARGE_GAP_SCALES:
                if scale:
                    value = tuple(round(float(low + scale * (high - low)), 6) for low, high in zip(
                        params.ocv_voltage_v, params.ocv_charge_voltage_v))
                    why = ('the preset\'s charge branch at %g of its gap above the discharge branch: the replay '
                           'of the fitted part is closer' % scale)
                else:
                    value, why = (), ('no hysteresis: the replay of the fitted part is closer without the '
                                      'preset\'s charge branch')
                other = replace(result, params=replace(params, ocv_charge_voltage_v=value),
                                fitted=dict(these_fitted), warnings=list(these_warnings))
                other.fitted['ocv_charge_voltage_v'] = Fitted(value, why)
                score = replayed_fit_rmse(other)
                if score < VARIANT_GAIN * base:
                    built.append((score, index, other))
    best_of = {}
    for item in built:   # per OCV kind, with or without hysteresis, the one the replay prefers
        if item[1] not in best_of or item[0] < best_of[item[1]][0]:
            best_of[item[1]] = item
    built = [best_of[index] for index in sorted(best_of)]
    if len(built) > 1:
        (plain_rmse, _, plain_result), (curve_rmse, _, curve_result) = built
        if curve_rmse < plain_rmse:
            curve_result.fitted['ocv_voltage_v'].source += ('; kept: the replay of the fitted part %.1f mV per '
                                                            'cell with it, %.1f mV with the preset\'s shape' % (
                                                                1000 * curve_rmse / cells_series,
                                                                1000 * plain_rmse / cells_series))
            chosen = curve_result
        else:
            plain_result.warnings.append('a learned OCV curve fitted better but replayed the fitted part worse '
                                         '(%.1f against %.1f mV per cell): the preset\'s shape kept' % (
                                             1000 * curve_rmse / cells_series, 1000 * plain_rmse / cells_series))
            chosen = plain_result
    else:
        curve_rmse, _, chosen = built[0]
        plain_rmse = curve_rmse
    return min(plain_rmse, curve_rmse), chosen


def _remapped_chemistry(masks, chemistry, electrical, has_rest, fitted):
    """The chemistry with its OCV tables read at SOC a + b x instead of x (a BMS's percentage spans a window of
    the cells' charge, and cells of one chemistry differ in slope), where that fits the fitted part at least
    REMAP_GAIN better; else None."""
    from scipy.optimize import least_squares
    low, high = fitted_soc_range(electrical, masks)
    if high - low < LEARN_MIN_SOC_SPAN:   # a slope is not told over less (the BMW i3's A14, 80-83 %:
        return None   # 0.34 + 0.56 x, and its next drive at 63-75 % 32.7 mV per cell off)
    names = (['offset'] if has_rest else []) + ['r0_ohm', 'r1_ohm', 'r_fast_ohm']

    def system(z, part):
        rows, targets = [], []
        for (a, soc, _, x0, x1, xf), mask in zip(electrical.pieces, masks):
            index = np.flatnonzero(mask)
            cut = int(len(index) * REMAP_TRAIN)
            mask = np.zeros(len(soc), dtype=bool)
            mask[index[:cut] if part == 'train' else index[cut:] if part == 'test' else index] = True
            where = np.clip(z[0] + z[1] * soc[mask], 0.0, 1.0)
            ocv = np.interp(where, chemistry.soc_points, chemistry.ocv) + a.weight[mask] * np.interp(
                where, chemistry.soc_points, chemistry.gap)
            columns = [x0[mask], x1[mask], xf[mask]]
            if has_rest:
                columns.insert(0, np.ones(mask.sum()))
            rows.append(np.column_stack(columns))
            targets.append(a.cell_voltage[mask] - ocv)
        return np.vstack(rows), np.concatenate(targets)

    def residual(z, part='all'):
        return non_negative_lstsq(*system(z, part), names)[2]

    def predicted(z):
        """RMSE of the last part of each fitted part, predicted from the first (the direction a log goes on)."""
        values = non_negative_lstsq(*system(z, 'train'), names)[0]
        design, target = system(z, 'test')
        return float(np.sqrt(np.mean((target - design @ np.array([values[n] for n in names])) ** 2)))
    before = float(np.sqrt(np.mean(residual([0.0, 1.0]) ** 2)))
    solution = least_squares(lambda z: residual(z, 'train'), [0.0, 1.0],
                             bounds=([-0.5, REMAP_SLOPE[0]], [0.5, REMAP_SLOPE[1]]), x_scale='jac', diff_step=1e-3,
                             max_nfev=60)
    after = float(np.sqrt(np.mean(residual(solution.x) ** 2)))
    at_bound = any(np.isclose(solution.x, [-0.5, REMAP_SLOPE[0]], atol=1e-3)) or \
        any(np.isclose(solution.x, [0.5, REMAP_SLOPE[1]], atol=1e-3))   # at a bound: the logs do not place it
    if at_bound or not (after < REMAP_GAIN * before and predicted(solution.x) < predicted([0.0, 1.0])):
        return None
    start, slope = (float(v) for v in solution.x)
    p = chemistry.params
    # below REMAP_JOIN (or the fitted part's lowest SOC) the scale returns to the preset's SOC 0, joined there:
    # a stretched scale's own SOC 0 would sit near the fitted part's voltage, and the model's cut-off (at or
    # above the table's start) then cut off a drive's heavier loads (BMW i3 B02: 3.72 V per cell, held out 70
    # mV per cell); joined at the fitted part's lowest SOC instead, the next drive 5 % lower fell off the
    # stretched slope (A08 then A09: 60 mV per cell)
    lowest_soc = min([REMAP_JOIN] + [float(np.min(piece[1][mask]))
                                     for piece, mask in zip(electrical.pieces, masks)])
    x = chemistry.soc_points
    if 1e-3 < lowest_soc < 1.0 - 1e-3 and np.min(np.abs(x - lowest_soc)) > 1e-3:   # the join a point of the table
        x = np.sort(np.concatenate([x, [round(lowest_soc, 4)]]))
    joined = x * (start + slope * lowest_soc) / max(lowest_soc, 1e-6)
    where = np.clip(np.where(x >= lowest_soc, start + slope * x, joined), 0.0, 1.0)
    volts = increasing(np.interp(where, chemistry.soc_points, chemistry.ocv))
    changes = {'ocv_soc': tuple(float(v) for v in x), 'ocv_voltage_v': tuple(float('%.5f' % v) for v in volts)}
    if p.ocv_charge_voltage_v:
        gap = np.interp(where, chemistry.soc_points, chemistry.gap)
        changes['ocv_charge_voltage_v'] = tuple(float('%.5f' % v) for v in increasing(volts + gap))
    changes['cell_charge_voltage_v'] = min(p.cell_charge_voltage_v, changes['ocv_voltage_v'][-1])
    changes['cell_cutoff_voltage_v'] = max(p.cell_cutoff_voltage_v, changes['ocv_voltage_v'][0])
    lowest = min(float(np.min(piece[0].cell_voltage[mask])) for piece, mask in zip(electrical.pieces, masks))
    if changes['cell_cutoff_voltage_v'] > lowest:   # its SOC 0 above what the log went through: the model would
        return None                                 # disconnect where the battery did not
    fitted['ocv_soc_scale'] = Fitted('%.4f + %.4f x' % (start, slope),
                                     'the preset\'s OCV read at this SOC: the fitted part %.1f mV per cell against '
                                     '%.1f mV on the preset\'s own SOC scale' % (1000 * after, 1000 * before))
    try:
        return Chemistry(replace(p, **changes))
    except ParameterError:
        return None


def _assemble(logs, masks, electrical, curve, heat_params, loads, chemistry, chemistry_name, cells_series,
              cells_parallel, has_rest, fitted, kept, warnings, level_source):
    """The fitted parameters from the parts (FitError when they break the model's rules)."""
    chemistry_params = chemistry.params
    changes = electrical_values(electrical, curve, chemistry, cells_series, cells_parallel, has_rest,
                                 fitted, kept, warnings, level_source)
    if curve is not None and chemistry_params.chemistry != 'lfp':
        _table_down_to_the_logs_cut_off(logs, masks, cells_series, curve, changes, fitted)
    changes.update(loads)
    changes.update(fit_charger(logs, masks, cells_series, cells_parallel, chemistry_params, changes, fitted, kept))
    changes.update(heat_params['changes'])
    changes.update(current_limits(logs, masks, cells_series, cells_parallel, chemistry_params, changes, fitted))
    cutoff_warning(logs, masks, cells_series, changes, warnings)
    changes['cells_series'] = cells_series
    changes['cells_parallel'] = cells_parallel
    changes['profile_current_timing'] = _current_timing(logs, fitted, warnings)
    changes['name'] = 'fitted'
    changes['source'] = 'battery_fit from %d log%s over the %s preset' % (len(logs), 's' * (len(logs) > 1),
                                                                          chemistry_name)
    for name, value in changes.items():
        if isinstance(value, float) and not math.isfinite(value):
            raise FitError('the fit gave %s = %r: the log cannot be fitted' % (name, value))
    try:
        return replace(chemistry_params, **changes)
    except ParameterError as error:
        raise FitError('the fitted values break the model\'s rules (%s): the log cannot be fitted with the %s '
                       'preset; try --chemistry or --cells-series' % (error, chemistry_name)) from None


def _table_down_to_the_logs_cut_off(logs, masks, cells_series, curve, changes, fitted):
    """A learned curve that reaches SOC 0 (the fitted part discharged to empty) starts at the lowest voltage the
    fitted part went through where that lies below the curve's first point, the cut-off with it: the model's
    cut-off sits at or above the table's start, and above the log's it disconnected where the cell went on
    (LG HG2 at C/20: the curve's smoothness put SOC 0 at 2.909 V, the cycler discharged on to 2.80 V; the model
    stopped 1 % of SOC early and sat 30-110 mV above the cell's rest and the charge after it)."""
    volts = list(changes['ocv_voltage_v'])
    lowest = min(float(np.min(log.voltage_v[mask])) for log, mask in zip(logs, masks)) / cells_series
    if curve['knots'][0] > 1e-4 or changes['ocv_soc'][0] != 0.0 or not lowest < volts[0]:
        return
    volts[0] = float('%.5f' % lowest)
    changes['ocv_voltage_v'] = tuple(volts)
    changes['cell_cutoff_voltage_v'] = min(changes['cell_cutoff_voltage_v'], volts[0])
    fitted['cell_cutoff_voltage_v'] = Fitted(volts[0], 'the lowest voltage the fitted part went through, at the '
                                             'learned curve\'s SOC 0 (the OCV table starts there)')


def _current_timing(logs, fitted, warnings):
    """The logs' current timing (conventions.current_measured_at_sample), for the config: battery_replay of a
    log's own current follows it. Logs that differ: the most's, warned."""
    timings = [log.current_timing for log in logs]
    timing = max(sorted(set(timings)), key=timings.count)
    if len(set(timings)) > 1:
        warnings.append('the logs differ in when their current was measured (%s): %s written, which battery_replay '
                        'follows for every profile' % (', '.join(timings), timing))
    if timing != 'until_next_row':
        fitted['profile_current_timing'] = Fitted(timing, 'the logged voltage answers the current of its own '
                                                  'sample (measured at the same instant): battery_replay takes '
                                                  'each row\'s current as the one since the previous row')
    return timing


def replayed_fit_rmse(result):
    """The voltage RMSE (pack V) of the fitted samples as battery_replay computes it (long logs thinned)."""
    from battery_simulator.core.fit.report import replayed_rmse
    return replayed_rmse(result, REPLAY_CHECK_SAMPLES)


def rmse(values):
    values = np.asarray(values)
    return float(np.sqrt(np.mean(values ** 2))) if len(values) else math.nan
