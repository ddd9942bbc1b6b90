"""What the logs fix before any fit (no ROS): their units checked, the fitted part of each, whether it rests,
and the charge they pin without the OCV's shape (Known: the capacity and starting SOCs from the logged
percentage, or from a CC-CV charge's end and a cut-off)."""
from dataclasses import dataclass, replace

import numpy as np

from battery_simulator.core.fit import FitError, Fitted
from battery_simulator.core.fit.circuit import counted_charge_ah

#: a rest: |current| below this fraction of the log's largest (or REST_A) for at least REST_S
REST_FRACTION, REST_A, REST_S = 0.02, 0.05, 120.0
#: a charge: charging current for at least this long, s
CHARGE_MIN_S = 120.0
#: the logged percentage gives the capacity beside a learned OCV curve when it moves by this much
PERCENTAGE_SPAN = 0.005
#: a current this many amperes per volt of the battery (99th percentile) is no battery's: milliamperes
MILLIAMPERES_PER_VOLT = 60.0
#: a battery voltage above this is millivolts
MILLIVOLTS_V = 1500.0
#: a log whose largest current is below this C-rate while sampled this far apart has stamps in ms
MILLISECONDS_C_RATE, MILLISECONDS_PERIOD_S = 0.01, 10.0
#: samples per log whose pairs give the percentage's slope against the counted charge
PAIR_SAMPLES = 300
#: a pair counts where the charge between its samples is at least this fraction of the log's range: over a long
#: standstill the count moves by the current sensor's noise alone and the percentage not at all (a robot's 24 h
#: log at 10 Hz standing at its cut-off for hours: the slopes near 0 took the capacity to 10.8 Ah from 9.6)
PAIR_MIN_CHARGE = 0.005
#: a discharge ends at empty (a cut-off) where its voltage falls over its last KNEE_SPAN of time at least
#: KNEE_RATE times its median rate (LG HG2 at C/20: 0.26 V in its last hour, 0.06 V an hour before)
KNEE_SPAN, KNEE_RATE = 0.05, 3.0
#: how far a known capacity (log) or starting SOC may move in the fit
KNOWN_SPREAD = 0.01
#: a rest after a cut-off this long shows the OCV there; a cut-off's SOC from it taken at most CUTOFF_SOC_MAX
#: (a cold cell cuts off far above the table's knee and relaxes higher: its capacity stays within 4 % of the
#: charge counted to its cut-off, the cycler's figure)
CUTOFF_REST_S, CUTOFF_SOC_MAX = 60.0, 0.04
#: a gap in a log's source filled by linear interpolation: at least INTERPOLATED_SAMPLES samples on which the
#: voltage and the current both lie on a straight line in time (within the column's rounding step) and each moves
#: by at least INTERPOLATED_STEPS rounding steps (a measured signal's noise never does; a rest or a constant
#: current does not move)
INTERPOLATED_SAMPLES, INTERPOLATED_STEPS = 30, 10


@dataclass
class Known:
    """The charge the logs fix without the OCV's shape: the pack capacity and each log's starting SOC from
    the logged percentage (a BMS's coulomb count), or from a full charge and a cut-off."""

    capacity_ah: float = None      # pack
    soc0: list = None              # per log, or None
    full_at: list = None           # per log: the sample where a CC-CV charge ended (SOC 1), or None
    source: str = ''
    empty_at: list = None          # per log, where no full charge fixes the start: a cut-off's sample (SOC 0)
    empty_rest_v: float = None     # the voltage a rest after the capacity's cut-off relaxed to (pack), or None
    empty_rest_at: tuple = None    # (log, sample) where that rest ends, or None
    cutoff_soc: float = 0.0        # the SOC of that rest's voltage on the table (pinned_at_dynamic_cutoff)

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
        full_at, empty_at = ([None if f is None else f // step for f, step in zip(marks, steps)]
                             if marks is not None else None for marks in (self.full_at, self.empty_at))
        rest_at = None if self.empty_rest_at is None else (
            self.empty_rest_at[0], self.empty_rest_at[1] // steps[self.empty_rest_at[0]])
        return replace(self, full_at=full_at, empty_at=empty_at, empty_rest_at=rest_at)

    def start_pin(self, k):
        """('full' or 'empty', sample) fixing log ``k``'s start with the capacity, or None."""
        if self.soc0 is not None:
            return None
        if self.full_at is not None and self.full_at[k] is not None:
            return 'full', self.full_at[k]
        if self.empty_at is not None and self.empty_at[k] is not None:
            return 'empty', self.empty_at[k]
        return None


def known_charge(logs, masks):
    """Known from the fitted part of the logs (all None where they fix nothing)."""
    gauge = _percentage_capacity(logs, masks)
    if gauge:
        return Known(capacity_ah=gauge[0], soc0=gauge[1], source='the logged percentage against the counted charge')
    full_at = [_full_charge_end(log, mask) for log, mask in zip(logs, masks)]
    capacity = None
    rest_v = rest_at = None
    for k, (log, mask, full) in enumerate(zip(logs, masks, full_at)):
        empty = _cutoff_end(log, mask)
        if full is not None and empty is not None:
            charge = counted_charge_ah(log)
            capacity = abs(charge[full] - charge[empty])
            rest_end = _rest_after(log, mask, empty)
            if rest_end is not None:
                rest_v, rest_at = float(log.voltage_v[rest_end]), (k, rest_end)
            break
    if capacity is None and all(f is None for f in full_at):
        # no full charge: a cut-off still pins SOC 0 (the start is then the charge counted to it over the
        # capacity: a learned curve cannot stretch the SOC scale below the start)
        empty_at = [_cutoff_end(log, mask, knee=True) for log, mask in zip(logs, masks)]
        if any(e is not None for e in empty_at):
            return Known(empty_at=empty_at, source='a cut-off (SOC 0)')
        return Known()
    return Known(capacity_ah=capacity, full_at=full_at, empty_rest_v=rest_v, empty_rest_at=rest_at,
                 source='a CC-CV charge\'s end (SOC 1)' + (' and a cut-off (SOC 0)' if capacity else ''))


def runs(flags):
    """(start, stop) of each run of True in ``flags``, ``stop`` past its last sample."""
    edges = np.flatnonzero(np.diff(np.concatenate([[0], flags.astype(int), [0]])))
    return list(zip(edges[::2], edges[1::2]))


def _small_current_a(log, mask):
    """A current that counts as none in this log: 2 % of its largest in the fitted part, at least 0.02 A."""
    return max(0.02, 0.02 * float(np.max(np.abs(log.current_a[mask]))))


def _full_charge_end(log, mask):
    """The last sample of the last CC-CV charge in the fitted part that tapered at constant voltage."""
    i, v, t = log.current_a, log.voltage_v, log.time_s
    threshold = _small_current_a(log, mask)
    found = None
    for start, stop in runs(mask & (i > threshold)):
        if t[stop - 1] - t[start] < CHARGE_MIN_S or stop - start < 10:
            continue
        peak, top = float(np.max(i[start:stop])), float(np.max(v[start:stop]))
        tail = slice(start + (stop - start) * 3 // 4, stop)
        if i[stop - 1] < 0.3 * peak and np.min(v[tail]) > top * 0.99:
            found = stop - 1
            # the taper goes on below the threshold to the charger's termination current: full is where it ends
            # (the A123 cell's taper from 0.066 A to 0.055 A put in 0.0036 Ah, 0.35 % of its capacity)
            while found + 1 < len(i) and mask[found + 1] and i[found + 1] > 0.0 and v[found + 1] > top * 0.99:
                found += 1
    return found


def _cutoff_end(log, mask, knee=False):
    """The last sample of a lasting discharge in the fitted part that ended at the part's lowest voltage (with
    ``knee``: its voltage falling over its last KNEE_SPAN at least KNEE_RATE times its median rate, as a
    cell's does at empty; a discharge stopped at half charge ends at its lowest voltage too)."""
    i, v, t = log.current_a, log.voltage_v, log.time_s
    threshold = _small_current_a(log, mask)
    lowest = float(np.min(v[mask]))
    last = int(np.flatnonzero(mask)[-1])
    found = None
    for start, stop in runs(mask & (i < -threshold)):
        if t[stop - 1] - t[start] < CHARGE_MIN_S or stop - start < 10 or stop > last:
            continue   # (a discharge the fitted part cuts short is no cut-off)
        end = min(stop, len(v) - 1)   # the last discharging sample's current flowed until this one
        if min(v[stop - 1], v[end]) <= lowest * 1.01 and \
                np.std(i[start:stop]) < 0.1 * abs(float(np.mean(i[start:stop]))) and \
                (not knee or _ends_in_a_knee(t[start:stop], v[start:stop])):
            found = end
    return found


def _rest_after(log, mask, end):
    """The sample at the end of a rest of at least CUTOFF_REST_S that begins at sample ``end`` (a cut-off's)
    within the fitted part, or None."""
    i, t = log.current_a, log.time_s
    threshold = _small_current_a(log, mask)
    last = end
    while last + 1 < len(i) and mask[last + 1] and abs(i[last]) <= threshold:
        last += 1   # (sample last's voltage answers the current of the interval before it)
    if abs(i[last]) > threshold:
        last -= 1
    return last if last > end and t[last] - t[end] >= CUTOFF_REST_S else None


def pinned_at_dynamic_cutoff(known, chemistry_params, cells_series, fitted):
    """``known`` with its capacity counted to the table's SOC 0 where the chemistry's table puts a loaded
    cut-off above it (LFP, core/lfp_tables.py: the cell relaxes by 0.6-0.7 V after a cut-off at 2.0 V, and
    lighter loads take 1 % more charge from full): the SOC of the voltage the rest after the cut-off
    relaxed to, on the discharge branch, is that cut-off's; the capacity from full to it is 1 - that SOC."""
    if chemistry_params.chemistry != 'lfp' or known.capacity_ah is None or known.empty_rest_v is None:
        return known
    volts = known.empty_rest_v / cells_series
    soc = float(np.interp(volts, chemistry_params.ocv_voltage_v, chemistry_params.ocv_soc))
    if not soc > 0.0:
        return known
    taken = min(soc, CUTOFF_SOC_MAX)
    fitted['cutoff_soc'] = Fitted(round(taken, 4), 'the cut-off under load is not empty: the rest after it relaxed '
                                  'to %.3f V per cell, the OCV at SOC %.4f%s; the capacity from full to it %.4g Ah, '
                                  'so %.4g Ah to the table\'s SOC 0' % (
                                      volts, soc, ' (taken at most %g)' % CUTOFF_SOC_MAX if soc > taken else '',
                                      known.capacity_ah, known.capacity_ah / (1.0 - taken)))
    soc = taken
    return replace(known, capacity_ah=known.capacity_ah / (1.0 - soc), cutoff_soc=soc)


def _ends_in_a_knee(t, v):
    """Whether a discharge's voltage falls over its last KNEE_SPAN of time at least KNEE_RATE times as fast as
    its median over the run."""
    rates = -np.diff(v) / np.maximum(np.diff(t), 1e-9)
    if len(rates) < 10:
        return False
    tail = t[1:] >= t[-1] - KNEE_SPAN * (t[-1] - t[0])
    return float(np.mean(rates[tail])) >= KNEE_RATE * max(float(np.median(rates)), 1e-9)


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


def cutoff_warning(logs, masks, cells_series, changes, warnings):
    lowest = min(float(np.min(log.voltage_v[mask])) for log, mask in zip(logs, masks)) / cells_series
    cutoff = changes['cell_cutoff_voltage_v']
    if lowest < cutoff:
        warnings.append('the logs go below the cut-off: %.3f V per cell against %.3f V (the model disconnects the '
                        'load there; a wrong chemistry or series count?)' % (lowest, cutoff))


def fit_mask(log, holdout):
    t = log.time_s
    mask = t <= t[-1] * (1.0 - holdout) if holdout > 0 else np.ones(len(t), dtype=bool)
    if mask.sum() < 10:
        raise FitError('%s: too short to fit with %g held out: %d samples before the held-out part'
                       % (log.name, holdout, mask.sum()))
    return mask


def log_has_rest(log, mask):
    i, t = np.abs(log.current_a), log.time_s
    still = mask & (i <= max(REST_A, REST_FRACTION * float(i[mask].max())))
    # the longest run of still samples (a sample left out of the fit, such as a filled gap's, ends a run)
    best, start = 0.0, None
    for k in range(len(i)):
        if still[k]:
            start = t[k] if start is None else start
            best = max(best, t[k] - start)
        else:
            start = None
    return best >= REST_S


def preset_temperature(log, chemistry):
    if log.temperature_c is not None:
        return log.temperature_c
    return np.full(len(log.time_s), chemistry.params.ambient_temperature_c)


def _percentage_capacity(logs, masks):
    """(pack capacity, starting SOC per log) from the logged percentage against the counted charge, where
    every log has it and it moves by PERCENTAGE_SPAN in all; else None. The slope is the median of the
    slopes between pairs of samples of one log (Theil-Sen): a stretch where the BMS's percentage and the
    logged current disagree (a winter drive's first minutes: 3.6 Ah drawn, 1.8 % counted) moves a least-squares
    line (105.9 Ah from a 61.7 Ah pack) but not the median (63.6 Ah)."""
    slopes, pieces = [], []
    for log, mask in zip(logs, masks):
        if log.percentage is None:
            return None
        charge = counted_charge_ah(log)
        use = np.flatnonzero(mask & np.isfinite(log.percentage))
        if len(use) < 10:
            return None
        use = use[::max(1, len(use) // PAIR_SAMPLES)]
        q, p = charge[use], log.percentage[use]
        first, second = np.triu_indices(len(use), 1)
        stretch = np.cumsum(~mask)[use]   # pairs within one stretch of fitted samples: across a sample left out (a
        keep = stretch[first] == stretch[second]   # filled gap's current) the charge between them is not the log's
        first, second = first[keep], second[keep]
        dq = q[second] - q[first]
        moved = np.abs(dq) > PAIR_MIN_CHARGE * np.ptp(q)
        slopes.append((p[second] - p[first])[moved] / dq[moved])
        pieces.append((q, p))
    if max(np.ptp(p) for _, p in pieces) < PERCENTAGE_SPAN or not sum(len(s) for s in slopes):
        return None
    slope = float(np.median(np.concatenate(slopes)))
    starts = [float(np.median(p - slope * q)) for q, p in pieces]
    if not slope > 0 or not all(-0.02 <= v <= 1.02 for v in starts):
        return None
    return 1.0 / slope, [min(max(v, 0.0), 1.0) for v in starts]


def interpolated(log):
    """The samples of ``log`` inside a gap of its source filled by linear interpolation (INTERPOLATED_SAMPLES):
    their voltage is no measurement. BMW i3 B02's first minutes: voltage and current straight from 386.0 V,
    -28.8 A to 370.1 V, -139.6 A over 160 s (the BMS's percentage moved 1.6 %, the current counts 3.6 Ah)."""
    t, v, i = log.time_s, log.voltage_v, log.current_a
    out = np.zeros(len(t), dtype=bool)
    steps = [_rounding_step(v), _rounding_step(i)]
    if len(t) < INTERPOLATED_SAMPLES or not all(q > 0 for q in steps):
        return out
    dt = np.maximum(np.diff(t), 1e-12)
    straight = np.ones(len(t), dtype=bool)
    for x, q in zip((v, i), steps):   # second differences within two rounding steps
        bend = np.abs(np.diff(np.diff(x) / dt)) * dt[1:]
        straight &= np.concatenate([[False], bend <= 2.0 * q + 1e-9, [False]])
    for start, stop in runs(straight):
        start, stop = start - 1, stop + 1   # a run's end samples lie on its line too
        if stop - start < INTERPOLATED_SAMPLES:
            continue
        span = t[start:stop]
        lines = [np.polyval(np.polyfit(span, x[start:stop], 1), span) for x in (v, i)]
        if all(np.max(np.abs(x[start:stop] - line)) <= q + 1e-9 and abs(line[-1] - line[0]) >= INTERPOLATED_STEPS * q
               for x, q, line in zip((v, i), steps, lines)):
            out[start:stop] = True
    return out


def _rounding_step(values):
    """The smallest step between a column's successive values (its logged resolution), 0 if it never moves."""
    steps = np.abs(np.diff(values))
    steps = steps[steps > 1e-9]
    return float(np.min(steps)) if len(steps) else 0.0
