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
from battery_simulator.core.fit.circuit import (Chemistry, counted_charge_ah, flowing_current, hat_basis,
                                                 log_arrays, regressors, state_of_charge, thermal)
from battery_simulator.core.parameter_rules import MAX_CELLS, ParameterError

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
PERCENTAGE_SPAN = 0.005
#: the series count is clear when the runner-up's fit is this many times worse than the best's
SERIES_CLEAR = 1.5
#: samples per log the series-count search looks at
SEARCH_SAMPLES = 2500
#: the fitted part replayed to check a learned OCV curve: at most this many samples (a longer log thinned)
REPLAY_CHECK_SAMPLES = 20000
#: a current this many amperes per volt of the battery (99th percentile) is no battery's: milliamperes
MILLIAMPERES_PER_VOLT = 60.0
#: a battery voltage above this is millivolts
MILLIVOLTS_V = 1500.0
#: a log whose largest current is below this C-rate while sampled this far apart has stamps in ms
MILLISECONDS_C_RATE, MILLISECONDS_PERIOD_S = 0.01, 10.0
#: the fitted ambient temperature is used when its uncertainty is below this, K (else the logged median)
AMBIENT_SIGMA_K = 5.0
#: a stretched SOC scale of the preset's OCV (its slope within these bounds) is fitted on the first
#: REMAP_TRAIN of each fitted part and taken where it fits the fitted part REMAP_GAIN better and predicts the
#: rest of the fitted part better than the preset's own scale
REMAP_GAIN, REMAP_SLOPE, REMAP_TRAIN = 0.85, (0.3, 3.0), 0.7
#: the config without hysteresis is taken where its replay of the fitted part is below this many times the
#: config's with the preset's hysteresis
VARIANT_GAIN = 0.8
#: the datasheet currents are raised to this many times the fitted part's largest
LIMIT_MARGIN = 2.0
#: how far a known capacity (log) or starting SOC may move in the fit
KNOWN_SPREAD = 0.01
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


def fit(logs, chemistry_params, chemistry_name, cells_series=None, holdout=DEFAULT_HOLDOUT, progress=None,
        alternatives=()):
    """A FitResult for ``logs`` (FitLogs of one robot) over the chemistry preset's parameters; with
    ``alternatives`` ((name, params) of other chemistry presets) the chemistry is found from the logs too."""
    progress = progress or (lambda fraction, text: None)
    warnings = []
    masks = [_fit_mask(log, holdout) for log in logs]
    fitted, kept = {}, {}
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
    cells_series, why, chemistry_name, chemistry_params = _series_count(
        logs, masks, candidates, known, cells_series, why, progress, warnings)
    fitted['cells_series'] = Fitted(cells_series, why)
    if len(candidates) > 1:
        fitted['chemistry'] = Fitted(chemistry_params.chemistry, 'the %s preset\'s shape fits the fitted part best '
                                     'of %s (another than the first only where %.3g times better)'
                                     % (chemistry_name, ', '.join(name for name, _ in candidates),
                                        1.0 / CHEMISTRY_CLEAR))
    chemistry = Chemistry(chemistry_params)
    # -- the electrical fit, with the model's temperature
    progress(0.25, 'capacity and resistances')
    has_rest = any(_has_rest(log, mask) for log, mask in zip(logs, masks))
    temperatures = [_preset_temperature(log, chemistry) for log in logs]
    electrical = _fit_electrical(logs, masks, chemistry, cells_series, 1, temperatures, has_rest, None, known=known)
    cells_parallel = parallel_count(electrical.capacity_ah, chemistry_params.cell_capacity_ah)
    heat_params = _fit_thermal(logs, masks, chemistry, cells_parallel, electrical, fitted, kept, warnings)
    temperatures = [_model_temperature(log, chemistry, cells_parallel, electrical, heat_params) for log in logs]
    progress(0.55, 'capacity and resistances (with the heat)')
    electrical = _fit_electrical(logs, masks, chemistry, cells_series, cells_parallel, temperatures, has_rest,
                                 electrical, known=known)
    check_capacity(logs, masks, electrical.capacity_ah)
    if known.soc0 is not None and not steady_current(logs):   # the percentage fixes the SOC: the preset's shape
        # may sit on it stretched
        remapped = _remapped_chemistry(masks, chemistry, electrical, has_rest, fitted)
        if remapped is not None:
            chemistry = remapped
            electrical = _fit_electrical(logs, masks, chemistry, cells_series, cells_parallel, temperatures,
                                         has_rest, electrical, known=known)
    progress(0.75, 'OCV curve')
    curve = None
    if steady_current(logs):
        for name in ('r0_ohm', 'r1_ohm', 'r_fast_ohm', 'tau1_s', 'tau_fast_s'):
            kept[name] = 'the current never steps (a constant-current test): the resistances cannot be told ' \
                         'from the OCV\'s level'
    else:
        curve = _learn_curve(logs, masks, chemistry, temperatures, electrical, has_rest, known)
    plain = (electrical, heat_params)
    for rounds in range(2):
        if curve is None:
            break
        # its resistances and time constants, the heat they make, the temperature, and the curve again at it
        coefficients = dict(electrical.coefficients)
        coefficients.update((name, (value, curve['sigmas'].get(name))) for name, value in curve['resistances'].items())
        electrical = replace(electrical, tau1_s=curve['tau1_s'], tau_fast_s=curve['tau_fast_s'], soc0=curve['soc0'],
                             coefficients=coefficients, capacity_ah=curve['capacity_ah'])
        heat_params = _fit_thermal(logs, masks, chemistry, cells_parallel, electrical, {}, {}, [])
        if rounds == 0 and any(log.temperature_c is not None for log in logs):
            temperatures = [_model_temperature(log, chemistry, cells_parallel, electrical, heat_params) for log in logs]
            curve = _learn_curve(logs, masks, chemistry, temperatures, electrical, has_rest, known) or curve
        else:
            break
    progress(0.85, 'loads and charger')
    loads = _fit_loads(logs, masks, cells_series, chemistry_params, fitted, kept)
    choices = [(None, plain[0], plain[1])] + ([(curve, electrical, heat_params)] if curve is not None else [])
    built = []
    for index, (which, this_electrical, this_heat) in enumerate(choices):
        these_fitted, these_kept, these_warnings = dict(fitted), dict(kept), list(warnings)
        if this_heat is not plain[1]:   # the heat of the curve's resistances, said in this result
            _fit_thermal(logs, masks, chemistry, cells_parallel, this_electrical, these_fitted, these_kept,
                         these_warnings)
        params = _assemble(logs, masks, this_electrical, which, this_heat, loads, chemistry, chemistry_name,
                           cells_series, cells_parallel, has_rest, these_fitted, these_kept, these_warnings)
        result = FitResult(params=params, chemistry=chemistry_name, fitted=these_fitted, kept=these_kept,
                           warnings=these_warnings, logs=logs, initial_soc=list(this_electrical.soc0),
                           fit_masks=masks)
        built.append((replayed_fit_rmse(result), index, result))
        progress(0.9 + 0.03 * index, 'the OCV curve checked by replay')
        if params.ocv_charge_voltage_v:
            # a sensor's noise at rest, replayed, walks the hysteresis state: none, taken only where the replay
            # of the fitted part is clearly closer (a tie says nothing of what the charge branch is worth)
            base = built[-1][0]
            for name, value, why in (('ocv_charge_voltage_v', (), 'no hysteresis: the replay of the fitted part '
                                      'is closer without the preset\'s charge branch'),):
                other = replace(result, params=replace(params, **{name: value}), fitted=dict(these_fitted),
                                warnings=list(these_warnings))
                other.fitted[name] = Fitted(value, why)
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
        chosen = built[0][2]
    progress(1.0, 'done')
    return chosen


def _remapped_chemistry(masks, chemistry, electrical, has_rest, fitted):
    """The chemistry with its OCV tables read at SOC a + b x instead of x (a BMS's percentage spans a window of
    the cells' charge, and cells of one chemistry differ in slope), where that fits the fitted part at least
    REMAP_GAIN better; else None."""
    from scipy.optimize import least_squares
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
        return _non_negative_lstsq(*system(z, part), names)[2]

    def predicted(z):
        """RMSE of the last part of each fitted part, predicted from the first (the direction a log goes on)."""
        values = _non_negative_lstsq(*system(z, 'train'), names)[0]
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
    where = np.clip(start + slope * chemistry.soc_points, 0.0, 1.0)
    volts = _increasing(np.interp(where, chemistry.soc_points, chemistry.ocv))
    changes = {'ocv_voltage_v': tuple(float('%.5f' % v) for v in volts)}
    if p.ocv_charge_voltage_v:
        gap = np.interp(where, chemistry.soc_points, chemistry.gap)
        changes['ocv_charge_voltage_v'] = tuple(float('%.5f' % v) for v in _increasing(volts + gap))
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
              cells_parallel, has_rest, fitted, kept, warnings):
    """The fitted parameters from the parts (FitError when they break the model's rules)."""
    chemistry_params = chemistry.params
    changes = _electrical_values(electrical, curve, chemistry, cells_series, cells_parallel, has_rest,
                                 fitted, kept, warnings)
    changes.update(loads)
    changes.update(_fit_charger(logs, masks, cells_series, cells_parallel, chemistry_params, changes, fitted, kept))
    changes.update(heat_params['changes'])
    changes.update(_limits(logs, masks, cells_series, cells_parallel, chemistry_params, changes, fitted))
    _cutoff_warning(logs, masks, cells_series, changes, warnings)
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


def parallel_count(capacity_ah, cell_capacity_ah):
    """The parallel count of a pack of ``capacity_ah`` of the preset's cells (at most MAX_CELLS: then the
    cells are larger)."""
    return min(MAX_CELLS, max(1, int(round(capacity_ah / cell_capacity_ah))))


# -- the parts ------------------------------------------------------------------------------------------

@dataclass
class Known:
    """The charge the logs fix without the OCV's shape: the pack capacity and each log's starting SOC from
    the logged percentage (a BMS's coulomb count), or from a full charge and a cut-off."""

    capacity_ah: float = None      # pack
    soc0: list = None              # per log, or None
    full_at: list = None           # per log: the sample where a CC-CV charge ended (SOC 1), or None
    source: str = ''

    def starts(self, logs):
        """Each log's starting SOC when the capacity and every start are fixed, else None."""
        if self.capacity_ah is None:
            return None
        if self.soc0 is not None:
            return self.soc0
        if self.full_at is None or any(f is None for f in self.full_at):
            return None
        return [min(1.0, max(0.0, 1.0 - counted_charge_ah(log)[f] / self.capacity_ah))
                for log, f in zip(logs, self.full_at)]

    def thinned(self, steps):
        full_at = None if self.full_at is None else [None if f is None else f // step
                                                     for f, step in zip(self.full_at, steps)]
        return replace(self, full_at=full_at)


def known_charge(logs, masks):
    """Known from the fitted part of the logs (all None where they fix nothing)."""
    gauge = _percentage_capacity(logs, masks)
    if gauge:
        return Known(capacity_ah=gauge[0], soc0=gauge[1], source='the logged percentage against the counted charge')
    full_at = [_full_charge_end(log, mask) for log, mask in zip(logs, masks)]
    capacity = None
    for log, mask, full in zip(logs, masks, full_at):
        empty = _cutoff_end(log, mask)
        if full is not None and empty is not None:
            charge = counted_charge_ah(log)
            capacity = abs(charge[full] - charge[empty])
            break
    if capacity is None and all(f is None for f in full_at):
        return Known()
    return Known(capacity_ah=capacity, full_at=full_at,
                 source='a CC-CV charge\'s end (SOC 1)' + (' and a cut-off (SOC 0)' if capacity else ''))


def _runs(flags):
    edges = np.flatnonzero(np.diff(np.concatenate([[0], flags.astype(int), [0]])))
    return list(zip(edges[::2], edges[1::2]))


def _full_charge_end(log, mask):
    """The last sample of the last CC-CV charge in the fitted part that tapered at constant voltage."""
    i, v, t = log.current_a, log.voltage_v, log.time_s
    threshold = max(0.02, 0.02 * float(np.max(np.abs(i[mask]))))
    found = None
    for start, stop in _runs(mask & (i > threshold)):
        if t[stop - 1] - t[start] < CHARGE_MIN_S or stop - start < 10:
            continue
        peak, top = float(np.max(i[start:stop])), float(np.max(v[start:stop]))
        tail = slice(start + (stop - start) * 3 // 4, stop)
        if i[stop - 1] < 0.3 * peak and np.min(v[tail]) > top * 0.99:
            found = stop - 1
    return found


def _cutoff_end(log, mask):
    """The last sample of a lasting discharge in the fitted part that ended at the part's lowest voltage."""
    i, v, t = log.current_a, log.voltage_v, log.time_s
    threshold = max(0.02, 0.02 * float(np.max(np.abs(i[mask]))))
    lowest = float(np.min(v[mask]))
    found = None
    for start, stop in _runs(mask & (i < -threshold)):
        if t[stop - 1] - t[start] < CHARGE_MIN_S or stop - start < 10:
            continue
        end = min(stop, len(v) - 1)   # the last discharging sample's current flowed until this one
        if min(v[stop - 1], v[end]) <= lowest * 1.01 and \
                np.std(i[start:stop]) < 0.1 * abs(float(np.mean(i[start:stop]))):
            found = end
    return found


def check_units(logs, masks):
    """FitError naming the unit when a log's current looks like mA or its voltage like mV."""
    for log, mask in zip(logs, masks):
        volts = float(np.median(log.voltage_v[mask]))
        if volts > MILLIVOLTS_V:
            raise FitError('%s: the voltage looks like millivolts (median %.6g): the column must be in volts'
                           % (log.name, volts))
        amperes = float(np.percentile(np.abs(log.current_a[mask]), 99))
        if amperes > MILLIAMPERES_PER_VOLT * volts:
            raise FitError('%s: the current looks like milliamperes (%.6g at %.4g V; no battery gives %.0f A per '
                           'volt): the column must be in amperes' % (log.name, amperes, volts, amperes / volts))


def check_capacity(logs, masks, capacity_ah):
    """FitError naming the unit when the capacity found makes every current a trickle in a log sampled
    seconds apart: its stamps are milliseconds."""
    amperes = max(float(np.percentile(np.abs(log.current_a[mask]), 99)) for log, mask in zip(logs, masks))
    period = min(float(np.median(np.diff(log.time_s))) for log in logs)
    if amperes < MILLISECONDS_C_RATE * capacity_ah and period >= MILLISECONDS_PERIOD_S:
        raise FitError('%s: the time looks like milliseconds (samples %.4g apart, a %.4g Ah battery whose '
                       'largest current is %.2g C): the time column must be in seconds'
                       % (logs[0].name, period, capacity_ah, amperes / capacity_ah))


def _cutoff_warning(logs, masks, cells_series, changes, warnings):
    lowest = min(float(np.min(log.voltage_v[mask])) for log, mask in zip(logs, masks)) / cells_series
    cutoff = changes['cell_cutoff_voltage_v']
    if lowest < cutoff:
        warnings.append('the logs go below the cut-off: %.3f V per cell against %.3f V (the model disconnects the '
                        'load there; a wrong chemistry or series count?)' % (lowest, cutoff))


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


#: per-cell voltage a log of each chemistry can show beyond its cut-off and charge voltage (load, charge), V
CELL_VOLTAGE_MARGIN = {'below': 0.45, 'above': 0.2}
#: the series counts tried in full per chemistry (nearest its nominal voltage) when no percentage screens them
FULL_FIT_CANDIDATES = 6
#: another chemistry than the first (the preset given or Li-ion) is taken where its fit's RMSE is below this
#: fraction of the first's: over a short span of SOC a flat curve and a sloped one can fit nearly alike
CHEMISTRY_CLEAR = 0.7


def _series_count(logs, masks, candidates, known, cells_series, why, progress, warnings):
    """(series count, why, chemistry name, chemistry params): every count the fitted part's voltage range
    allows for each chemistry's cells, scored by the fit of that chemistry's OCV shape (no offset: the
    level is what tells the counts apart) in pack volts."""
    voltages = np.concatenate([log.voltage_v[mask] for log, mask in zip(logs, masks)])
    low, high = float(np.percentile(voltages, 0.1)), float(np.percentile(voltages, 99.9))
    short_logs, short_masks = [], []
    for log, mask in zip(logs, masks):
        step = max(1, len(log.time_s) // SEARCH_SAMPLES)
        short_logs.append(_thinned(log, step))
        short_masks.append(mask[::step])
    short_known = known.thinned([max(1, len(log.time_s) // SEARCH_SAMPLES) for log in logs])
    scores, tried = [], []
    for name, params in candidates:
        chemistry = Chemistry(params)
        if cells_series:
            counts = [cells_series]
        else:
            top = params.cell_charge_voltage_v + CELL_VOLTAGE_MARGIN['above']
            bottom = params.cell_cutoff_voltage_v - CELL_VOLTAGE_MARGIN['below']
            counts = list(range(max(1, math.ceil(high / top)), min(MAX_CELLS, int(low / bottom)) + 1))
        if not counts:
            continue
        screened = short_known.starts(short_logs)
        if screened is None and len(counts) > FULL_FIT_CANDIDATES:
            nominal = float(np.interp(0.5, chemistry.soc_points, chemistry.ocv))
            middle = float(np.median(voltages)) / nominal
            counts = sorted(sorted(counts, key=lambda n: abs(n - middle))[:FULL_FIT_CANDIDATES])
        tried.append('%s %s' % (name, _ranges(counts)))
        for count in counts:
            if screened is not None:
                score = _screen(short_logs, short_masks, chemistry, count, short_known.capacity_ah, screened)
            else:
                temperatures = [_preset_temperature(log, chemistry) for log in short_logs]
                try:
                    result = _fit_electrical(short_logs, short_masks, chemistry, count, 1, temperatures, False,
                                             None, max_evaluations=40, known=short_known)
                    score = result.rmse_v * count
                except FitError:
                    continue
            scores.append((score, count, name, params))
        progress(0.02 + 0.2 * len(tried) / len(candidates), 'series count')
    if not scores:
        raise FitError('no series count of %s cells fits the voltage range %.2f-%.2f V'
                       % (' or '.join(name for name, _ in candidates), low, high))
    scores.sort(key=lambda item: item[0])
    firsts = [item for item in scores if item[2] == candidates[0][0]]
    if firsts and firsts[0] is not scores[0] and not scores[0][0] < CHEMISTRY_CLEAR * firsts[0][0]:
        scores.remove(firsts[0])   # another chemistry only where it fits clearly better than the first
        scores.insert(0, firsts[0])
    score, best, name, params = scores[0]
    bests = {}
    for item in scores:
        bests.setdefault(item[2], item)
    tried = ['%s (best %d: %.3g V)' % (text, bests[text.split()[0]][1], bests[text.split()[0]][0])
             if text.split()[0] in bests else text for text in tried]
    if why is None:
        rivals = [item for item in scores[1:] if item[0] < SERIES_CLEAR * score and item[1] != best]
        if rivals:
            warnings.append('cells in series: %d fits best (%.3g V pack RMSE), but %d nearly as well (%.3g V); '
                            '--cells-series settles it' % (best, score, rivals[0][1], rivals[0][0]))
        why = ('the fitted part\'s voltage %.2f-%.2f V and the best fit of the OCV shape among %s cells%s'
               % (low, high, '; '.join(tried), ' (the SOC from the logged percentage)'
                  if known.soc0 is not None else ''))
    return best, why, name, params


def _ranges(counts):
    return '%d' % counts[0] if len(counts) == 1 else '%d-%d' % (counts[0], counts[-1])


def _screen(logs, masks, chemistry, count, capacity_ah, soc0):
    """Pack-volt RMSE of the chemistry's OCV shape plus resistances (least squares, preset time constants)
    with the SOC the logged percentage gives, for ``count`` cells in series."""
    p = chemistry.params
    parallel = parallel_count(capacity_ah, p.cell_capacity_ah)
    rows, targets = [], []
    for k, (log, mask) in enumerate(zip(logs, masks)):
        a = log_arrays(log, chemistry, count, parallel)
        soc = state_of_charge(a, capacity_ah / parallel, soc0[k], p.coulombic_efficiency)
        x0, _, xf = regressors(a, soc, chemistry.arrhenius(_preset_temperature(log, chemistry)), chemistry,
                               p.tau1_s, p.tau_fast_s, False)
        rows.append(np.column_stack([x0[mask], xf[mask]]))
        targets.append((a.cell_voltage - chemistry.ocv_at(soc, a.weight))[mask])
    # no slow RC pair: over a drive its long memory would stand in for the OCV's slope, the very thing that
    # tells the chemistries and the counts apart
    _, _, residual = _non_negative_lstsq(np.vstack(rows), np.concatenate(targets), ['r0_ohm', 'r_fast_ohm'])
    return float(np.sqrt(np.mean(residual ** 2))) * count


def _thinned(log, step):
    copy = replace(log)
    for name in ('time_s', 'voltage_v', 'current_a', 'temperature_c', 'percentage'):
        value = getattr(log, name)
        if value is not None:
            setattr(copy, name, value[::step])
    if step > 1:   # a thinned log's current: the mean over the new interval after each sample (the charge kept)
        picked = counted_charge_ah(log)[::step] * 3600.0
        span = np.diff(copy.time_s)
        copy.current_a = np.concatenate([np.diff(picked) / np.where(span > 0, span, 1.0), [log.current_a[-1]]])
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
                    max_evaluations=200, known=None):
    """The capacity, starting SOCs and time constants searched, the OCV offset and resistances solved; where
    no log's current steps (steady_current) the resistances and time constants are the preset's."""
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
    low = [z0[0] - math.log(20.0)] + [0.0] * n + [math.log(TAU1_BOUNDS[0]), math.log(TAU_FAST_BOUNDS[0])]
    high = [z0[0] + math.log(20.0)] + [1.0] * n + [math.log(TAU1_BOUNDS[1]), math.log(TAU_FAST_BOUNDS[1])]
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

    def starts(z):
        """Each log's starting SOC: searched, or 1 at a full charge's end."""
        capacity = math.exp(z[0])
        out = []
        for k in range(n):
            full = known.full_at[k] if known.full_at is not None and known.soc0 is None else None
            out.append(min(1.0, max(0.0, 1.0 - counted[k][full] / capacity)) if full is not None else float(z[1 + k]))
        return out

    def solve(z, use_tables):
        capacity = math.exp(z[0])
        tau1, tau_fast = math.exp(z[-2]), math.exp(z[-1])
        pieces, rows, targets = [], [], []
        soc0 = starts(z)
        for k, a in enumerate(arrays):
            soc = state_of_charge(a, capacity / cells_parallel, soc0[k], p.coulombic_efficiency)
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
        if steady:   # the preset's resistances: a steady current cannot tell them from the OCV
            preset_r = np.array([p.r0_ohm, p.r1_ohm, p.r_fast_ohm])
            target = target - design[:, -3:] @ preset_r
            values, sigmas, residual = _non_negative_lstsq(design[:, :-3], target, names[:-3])
            values.update(zip(names[-3:], preset_r.tolist()))
            return pieces, values, sigmas, residual
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
    return Electrical(capacity_ah=math.exp(solution.x[0]), soc0=starts(solution.x),
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


def _non_negative_lstsq(design, target, names):
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


def _learn_curve(logs, masks, chemistry, temperatures, electrical, has_rest, known=None):
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

    known = known or Known()
    counted = [np.cumsum(np.where(a.cell_current > 0, p.coulombic_efficiency * a.cell_current, a.cell_current)
                         * a.dt) / 3600.0 for a in arrays]   # per cell, Ah

    def starts(z):
        cell_capacity = math.exp(z[2]) / electrical.cells_parallel
        out = list(z[3:])
        for k in range(len(arrays)):
            full = known.full_at[k] if known.full_at is not None and known.soc0 is None else None
            if full is not None:   # SOC 1 at a full charge's end
                out[k] = min(1.0, max(0.0, 1.0 - counted[k][full] / cell_capacity))
        return out

    def solve(z):
        cell_capacity = math.exp(z[2]) / electrical.cells_parallel
        soc0 = starts(z)
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
        return (target - matrix @ small_lstsq(matrix, target))[:n]

    # the SOC scale stays the one the logs fix (the logged percentage, a full charge and a cut-off): a learned
    # curve must not stretch it; without them the curve's smoothness places it (checked by replay after)
    capacity, soc0 = math.log(known.capacity_ah or electrical.capacity_ah), electrical.soc0
    if known.soc0 is not None:
        soc0 = known.soc0
    z0 = [math.log(electrical.tau1_s), math.log(electrical.tau_fast_s), capacity] + list(soc0)
    spread = KNOWN_SPREAD if known.capacity_ah is not None else math.log(3.0)   # else: the replay checks it
    low_bounds = [math.log(TAU1_BOUNDS[0]), math.log(TAU_FAST_BOUNDS[0]), capacity - spread] + [
        max(0.0, s - 0.02) if known.capacity_ah is not None else 0.0 for s in soc0]
    high_bounds = [math.log(TAU1_BOUNDS[1]), math.log(TAU_FAST_BOUNDS[1]), capacity + spread] + [
        min(1.0, s + 0.02) if known.capacity_ah is not None else 1.0 for s in soc0]
    z0 = np.clip(z0, np.asarray(low_bounds) + 1e-9, np.asarray(high_bounds) - 1e-9)
    solution = least_squares(residuals, z0, bounds=(low_bounds, high_bounds), x_scale='jac', diff_step=1e-4,
                             max_nfev=60)
    for weight in [w for w in SMOOTHNESS if w >= weight]:   # the smoothest needed for an increasing curve
        grid, matrix, target, n = solve(solution.x)
        solved = np.linalg.lstsq(matrix, target, rcond=None)[0]
        if np.all(np.diff(solved[:count]) > 0):
            break
    # else the smoothest, made increasing below (_increasing): over a short span of a flat curve the noise can
    # bend it; the replay of the fitted part checks it against the preset's shape
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
            'soc0': [float(v) for v in starts(solution.x)], 'capacity_ah': math.exp(solution.x[2])}


def _percentage_capacity(logs, masks):
    """(pack capacity, starting SOC per log) from the logged percentage against the counted charge, where
    every log has it and it moves by PERCENTAGE_SPAN in all; else None."""
    rows, targets = [], []
    for index, (log, mask) in enumerate(zip(logs, masks)):
        if log.percentage is None:
            return None
        charge = counted_charge_ah(log)
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
    if not values[-1] > 0 or not all(-0.02 <= v <= 1.02 for v in values[:-1]):
        return None
    return 1.0 / values[-1], [float(min(max(v, 0.0), 1.0)) for v in values[:-1]]


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
                if (0 in subset) == (1 in subset):   # one idle term: a current or a power
                    continue
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
            fitted[name] = Fitted(0.0, 'one idle term, %s (it fits the standstill draw better)' % names[1 - j])
        elif not has_motion:
            kept[name] = 'no motion topic (cmd_vel / odometry) or linear_x / angular_z columns in the logs'
        else:
            changes[name] = 0.0
            fitted[name] = Fitted(0.0, 'the battery power does not grow with it')
    return changes


def _fit_charger(logs, masks, cells_series, cells_parallel, chemistry_params, changes, fitted, kept):
    """The charger from the charges in the fitted part of the logs."""
    p = chemistry_params
    # a charge: more than C/40 (a sensor's noise at rest is not one)
    threshold = max(0.05, changes['cell_capacity_ah'] * cells_parallel / 40.0)
    # a charge lasts (a vehicle's regeneration, pulses of charge current while it drives, is not one)
    masks = [_lasting(log.time_s, mask & (log.current_a > threshold), CHARGE_MIN_S) for log, mask in zip(logs, masks)]
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


def _limits(logs, masks, cells_series, cells_parallel, chemistry_params, changes, fitted):
    """The datasheet currents raised to what the fitted part shows (twice that: a later drive may ask for
    more), so the model never cuts the logged load off."""
    p = chemistry_params
    result = {}
    discharge = max(float(-np.min(log.current_a[mask])) for log, mask in zip(logs, masks)) / cells_parallel
    if discharge * LIMIT_MARGIN > p.cell_max_discharge_current_a:
        result['cell_max_discharge_current_a'] = float('%.4g' % (LIMIT_MARGIN * discharge))
        fitted['cell_max_discharge_current_a'] = Fitted(result['cell_max_discharge_current_a'],
                                                        'twice the fitted part\'s largest discharge current')
    charge = max(float(np.max(log.current_a[mask])) for log, mask in zip(logs, masks)) / cells_parallel
    limit = max(charge * LIMIT_MARGIN, changes.get('cell_max_charge_current_a', p.cell_max_charge_current_a),
                changes['charge_current_a'] / cells_parallel * 1.01)
    if limit > p.cell_max_charge_current_a:
        result['cell_max_charge_current_a'] = float('%.4g' % limit)
        fitted['cell_max_charge_current_a'] = Fitted(result['cell_max_charge_current_a'],
                                                     'twice the fitted part\'s largest charge current')
    load = changes.get('load_current_a', p.load_current_a)
    if load > result.get('cell_max_discharge_current_a', p.cell_max_discharge_current_a) * cells_parallel:
        result['cell_max_discharge_current_a'] = float('%.4g' % (1.2 * load / cells_parallel))
    return result


def _cell_heat(log, cells_parallel, electrical, scale):
    """The heat of one cell, W: the current through it (the replay's convention) squared times its resistance
    (the electrical fit's, per cell of its own parallel count: a cell of ``cells_parallel`` has Np / Np' times)."""
    i = flowing_current(log.current_a) / cells_parallel
    r = sum(electrical.coefficients[name][0] for name in ('r0_ohm', 'r1_ohm', 'r_fast_ohm'))
    return i * i * r * (cells_parallel / electrical.cells_parallel) * scale


def _fit_thermal(logs, masks, chemistry, cells_parallel, electrical, fitted, kept, warnings):
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
    if not (sigmas[0] < AMBIENT_SIGMA_K and sigmas[2] < 1.0):   # also NaN: the logs do not tell the ambient
        ambient = float(np.median(np.concatenate([log.temperature_c[mask] for log, mask, _ in pairs])))
        transfer = math.log(p.cell_heat_transfer_w_per_k)
        solution = least_squares(lambda z: residuals([ambient, z[0], transfer]), [solution.x[1]],
                                 bounds=([math.log(0.1)], [math.log(1e6)]), x_scale='jac', max_nfev=50)
        rmse = float(np.sqrt(np.mean(solution.fun ** 2)))
        capacity_sigma = _jacobian_sigmas(solution, rmse)[0]
        kept['cell_heat_transfer_w_per_k'] = ('the logged temperature does not tell the transfer to ambient from '
                                              'the ambient (the fit gave %.3g +- %.2g degC): the ambient set to the '
                                              'median logged temperature' % (heat['ambient'], sigmas[0]))
        heat.update(ambient=ambient, capacity=math.exp(solution.x[0]), transfer=p.cell_heat_transfer_w_per_k)
        sigmas = [0.0, capacity_sigma, math.inf]
    for name, value, sigma in (('ambient_temperature_c', heat['ambient'], sigmas[0]),
                               ('cell_heat_capacity_j_per_k', heat['capacity'], heat['capacity'] * sigmas[1]),
                               ('cell_heat_transfer_w_per_k', heat['transfer'], heat['transfer'] * sigmas[2])):
        if name in kept:
            continue
        if name != 'ambient_temperature_c' and not sigma < value:   # also NaN
            kept[name] = 'the fit gave %.3g +- %.2g: its uncertainty exceeds its value' % (value, sigma)
            heat['capacity' if 'capacity' in name else 'transfer'] = getattr(p, name)
            continue
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

