"""A log's conventions found and undone (no ROS): stamps, NaN, the current's sign, the percentage's scale.

sensor_msgs/BatteryState says: current positive while charging, percentage 0..1, NaN for what is not
measured. Gazebo's battery plugin and some drivers report discharge as positive current, some percentage
as 0..100; bags hold duplicated and out-of-order stamps. Each is detected and said in ``notes``.
"""
from dataclasses import dataclass, field, replace

import numpy as np

from battery_simulator.core.fit import FitError

#: fewer battery samples than this, or a shorter span, is too little to fit anything
MIN_SAMPLES = 20
MIN_SPAN_S = 60.0
#: a pause in the samples longer than this (and than GAP_FACTOR sampling periods) splits a log in two
GAP_S, GAP_FACTOR = 600.0, 20.0
#: a log of more samples than this is thinned to about this many (the charge kept): any log within minutes
MAX_SAMPLES = 150000
#: a current whose standard deviation is below this (after the sensor's noise) has no steps, A
MIN_CURRENT_SPREAD_A = 0.02
#: a constant-current log is fitted (capacity, OCV) where its voltage moves by at least this much, V
MIN_STEADY_VOLTAGE_SPAN_V = 0.05
#: a number larger than this in the voltage or current column is no measurement in any unit (an overflowed
#: field, 1e308): left out like NaN
NOT_A_MEASUREMENT = 1e9
#: a sensor's glitch, left out with a warning: a current above this many times the log's 99th percentile of
#: |current| (a CAN field's 327.67 A in a robot's 5 A log), a voltage outside this range of its median; more
#: than GLITCH_SHARE of the samples so far out is no glitch but two batteries or two units in one log: refused
GLITCH_CURRENT_FACTOR = 10.0
GLITCH_VOLTAGE_RANGE = (0.5, 2.0)
GLITCH_SHARE = 0.01
#: ... and whose voltage moves by less than this many times the log's median step between samples
GLITCH_VOLTAGE_ANSWER = 5.0
#: the time going back by more than this many sampling periods (and MIN_SPAN_S), a few times at most, is a
#: clock that restarted, not stamps out of order
RESTART_PERIODS, RESTARTS_AT_MOST = 100.0, 3
#: a percentage moving by more than this (0..1) between two samples closer than GAP_S is no gauge's: not used
PERCENTAGE_JUMP = 0.2
#: a median temperature above this is in kelvin
KELVIN_ABOVE_C = 150.0


@dataclass
class FitLog:
    """One log, ready to fit: arrays over the battery samples (current positive charging, percentage
    0..1 or NaN, temperature or None) and the motion (|v|, |w| as seen at each battery sample, or None)."""

    name: str
    time_s: np.ndarray
    voltage_v: np.ndarray
    current_a: np.ndarray
    temperature_c: np.ndarray = None
    percentage: np.ndarray = None
    #: the mean |v| and |w| over each sample's interval, and the latest command at each sample (None: no motion)
    speed_mean: np.ndarray = None
    turn_mean: np.ndarray = None
    speed_now: np.ndarray = None
    turn_now: np.ndarray = None
    source: str = ''
    current_inverted: bool = False
    #: the series count BatteryState.cell_voltage shows (0: none)
    cell_count: int = 0
    #: when the logged current flowed (BatteryParameters.profile_current_timing): 'since_previous_row' where
    #: the voltage answers the current of its own row (measured at the same instant); ``current_a`` holds
    #: the replay's convention either way (the current that flowed after each sample, until the next)
    current_timing: str = 'until_next_row'
    #: the current never steps (a constant-current test): the resistances are the preset's
    steady_current: bool = False
    notes: list = field(default_factory=list)


def prepare(raw, cmd_vel_timeout_s=0.5):
    """A FitLog from a RawLog; FitError (one line) when nothing can be fitted from it."""
    name = raw.name
    notes = list(raw.notes)
    t = np.asarray(raw.time_s, dtype=float)
    v = np.asarray(raw.voltage_v, dtype=float)
    i = np.asarray(raw.current_a, dtype=float)
    temp = np.asarray(raw.temperature_c, dtype=float) if len(raw.temperature_c) == len(t) else np.full(len(t), np.nan)
    pct = np.asarray(raw.percentage, dtype=float) if len(raw.percentage) == len(t) else np.full(len(t), np.nan)
    if len(t) == 0:
        raise FitError('%s: no battery samples' % name)
    if not np.isfinite(v).any() or not (v > 0).any():
        raise FitError('%s: every voltage is NaN or not positive (%d samples): nothing to fit' % (name, len(v)))
    if not np.isfinite(i).any():
        raise FitError('%s: every current is NaN (%d samples): the current is needed to fit' % (name, len(i)))
    usable = (np.isfinite(t) & np.isfinite(v) & (v > 0) & np.isfinite(i) & (np.abs(v) < NOT_A_MEASUREMENT)
              & (np.abs(i) < NOT_A_MEASUREMENT))
    if not usable.any():
        raise FitError('%s: no sample has a stamp, a voltage and a current a battery gives (%d samples)' % (name, len(t)))
    if (~usable).any():
        notes.append('%d of %d samples without a stamp, voltage or current (NaN, or beyond %.0e) left out'
                     % ((~usable).sum(), len(t), NOT_A_MEASUREMENT))
    t, v, i, temp, pct = t[usable], v[usable], i[usable], temp[usable], pct[usable]
    current_glitch, voltage_glitch = glitches(name, v, i)
    glitch = current_glitch | voltage_glitch
    if glitch.any():
        what = []
        if current_glitch.any():
            what.append('current up to %.6g A against %.3g A (the 99th percentile of the others)' % (
                np.max(np.abs(i[current_glitch])), np.percentile(np.abs(i[~glitch]), 99)))
        if voltage_glitch.any():
            what.append('voltage %.6g-%.6g V against %.4g V (the median)' % (
                np.min(v[voltage_glitch]), np.max(v[voltage_glitch]), np.median(v[~glitch])))
        notes.append('WARNING: %d samples far outside the others left out (a sensor\'s glitch?): %s'
                     % (glitch.sum(), '; '.join(what)))
        t, v, i, temp, pct = t[~glitch], v[~glitch], i[~glitch], temp[~glitch], pct[~glitch]
    if (np.diff(t) < 0).any():
        _refuse_a_restarted_clock(name, t)
        notes.append('%d stamps out of order: sorted' % (np.diff(t) < 0).sum())
        order = np.argsort(t, kind='stable')
        t, v, i, temp, pct = t[order], v[order], i[order], temp[order], pct[order]
    duplicate = np.concatenate([np.diff(t) == 0, [False]])
    if duplicate.any():
        notes.append('%d duplicated stamps: the last sample of each kept' % duplicate.sum())
        keep = ~duplicate
        t, v, i, temp, pct = t[keep], v[keep], i[keep], temp[keep], pct[keep]
    if len(t) < MIN_SAMPLES or t[-1] - t[0] < MIN_SPAN_S:
        raise FitError('%s: too short to fit: %d usable samples over %.0f s (at least %d samples over %.0f s)'
                       % (name, len(t), t[-1] - t[0] if len(t) else 0.0, MIN_SAMPLES, MIN_SPAN_S))
    if len(t) > MAX_SAMPLES:
        t, v, i, temp, pct = _decimated(t, v, i, temp, pct, notes)
    period = float(np.median(np.diff(t)))
    if period > GAP_S:   # every sample a pause: stamps in ns or ms (ROS stamps as integers), not a battery log
        unit = next((unit for unit, factor in (('milliseconds', 1e3), ('microseconds', 1e6), ('nanoseconds', 1e9))
                     if period / factor <= GAP_S), 'nanoseconds')
        raise FitError('%s: the samples are %.3g s apart (median): the time looks like %s; the time column must be '
                       'in seconds' % (name, period, unit))
    steady = bool(np.std(i) < MIN_CURRENT_SPREAD_A or np.ptp(i) < 4 * MIN_CURRENT_SPREAD_A)
    if steady and (abs(float(np.mean(i))) < 4 * MIN_CURRENT_SPREAD_A or np.ptp(v) < MIN_STEADY_VOLTAGE_SPAN_V):
        raise FitError('%s: the current is constant (%.3f A, spread %.3f A) and the voltage moves %.3f V: nothing to '
                       'identify; record a log with current steps (drive, stop, charge)'
                       % (name, np.mean(i), np.std(i), np.ptp(v)))
    log = FitLog(name=name, time_s=t - t[0], voltage_v=v, current_a=i, source=raw.source, notes=notes,
                 cell_count=_cell_count(raw, v, notes), steady_current=steady)
    if steady:
        notes.append('constant current (%.3f A): the capacity and the OCV from how the voltage moves; the '
                     'resistances and time constants the preset\'s (a current that never steps cannot tell them '
                     'from the OCV\'s level)' % np.mean(i))
    log.current_inverted = current_is_inverted(t, v, i)
    if log.current_inverted:
        log.current_a = -i
        notes.append('current sign: positive = discharging (as Gazebo\'s plugin reports it), found from how the '
                     'voltage moves with the current: turned to ROS\'s (positive = charging)')
    else:
        notes.append('current sign: ROS\'s (positive = charging), found from how the voltage moves with the current')
    if current_measured_at_sample(log.voltage_v, log.current_a):
        log.current_timing = 'since_previous_row'
        log.current_a = flowing_after(log.current_a)
        notes.append('current timing: the voltage answers the current of its own sample (measured at the same '
                     'instant): each sample\'s current flowed since the previous sample (the config says so: '
                     'profile_current_timing, which battery_replay follows)')
    else:
        notes.append('current timing: the voltage answers the previous sample\'s current: each sample\'s current '
                     'flowed until the next sample (battery_replay\'s default)')
    if np.isfinite(temp).sum() >= MIN_SAMPLES:
        median_c = float(np.nanmedian(temp))
        if median_c > KELVIN_ABOVE_C:
            raise FitError('%s: the temperature looks like kelvin (median %.6g): the column must be in degrees '
                           'Celsius' % (name, median_c))
        log.temperature_c = _filled(temp)
    else:
        notes.append('no temperature (NaN or absent): the preset\'s thermal values kept')
    pct = _usable_percentage(t, pct, notes)
    if pct is not None:
        log.percentage = pct
    if raw.motion_time_s is not None and len(raw.motion_time_s) > 0:
        _motion_at_samples(log, raw, t, cmd_vel_timeout_s)
    return log


#: the voltage answers its own sample's current where the least-squares step response at the same sample is
#: this many times the one at the next sample
AT_SAMPLE_RATIO = 2.0


def current_measured_at_sample(v, i):
    """Whether the voltage jumps at the sample where the current steps (both measured at the same instant:
    a cycler, BatteryState) rather than one sample later (a row's current held until the next row): the
    voltage's change regressed on the current's change at its own sample and at the one before, over the
    samples next to a step (current in ROS's sign)."""
    response = step_response(v, i)
    if response is None:
        return False
    same, following = response
    return abs(same) > AT_SAMPLE_RATIO * abs(following)


def step_response(v, i):
    """(same, following): the voltage's change per ampere of a current step at the step's own sample and at
    the next sample (least squares over the samples next to a step); None without 3 steps."""
    dv, di = np.diff(v), np.diff(i)
    if len(di) < 3:
        return None
    big = np.abs(di) > max(4.0 * float(np.median(np.abs(di))), 0.05 * float(np.ptp(i)), 2 * MIN_CURRENT_SPREAD_A)
    rows = np.flatnonzero(big[1:] | big[:-1]) + 1   # dv[j] against di[j] and di[j - 1]
    if big.sum() < 3 or len(rows) < 4:
        return None
    design = np.column_stack([di[rows], di[rows - 1]])
    (same, following), *_ = np.linalg.lstsq(design, dv[rows], rcond=None)
    return float(same), float(following)


def flowing_after(current_a):
    """A current measured at each sample's instant (it flowed since the previous sample) in the replay's
    convention: the current that flowed after each sample, until the next (the last sample's kept)."""
    current_a = np.asarray(current_a, dtype=float)
    return np.concatenate([current_a[1:], current_a[-1:]])


def as_logged(log):
    """``log``'s current as its log gave it (the inverse of flowing_after where the timing says so)."""
    if log.current_timing == 'since_previous_row':
        return np.concatenate([log.current_a[:1], log.current_a[:-1]])
    return log.current_a


def _cell_count(raw, voltage, notes):
    """The series count BatteryState.cell_voltage shows (0: none or not usable); a voltage field that is one
    cell's while the cells add up to a pack's is said, and the count is not used then."""
    if not raw.cell_count:
        return 0
    sums = np.asarray(raw.cell_sum_v, dtype=float)
    sums = sums[np.isfinite(sums)]
    if raw.cell_count > 1 and len(sums):
        ratio = float(np.median(sums)) / float(np.median(voltage))
        if ratio > 1.5:
            notes.append('WARNING: the voltage is %.3g times below the sum of BatteryState.cell_voltage (%d cells): '
                         'it looks like one cell\'s voltage given as the pack\'s; the series count is fitted from '
                         'the voltage as logged' % (ratio, raw.cell_count))
            return 0
    return raw.cell_count


def _decimated(t, v, i, temp, pct, notes):
    """Every step-th sample, the current the mean over each new interval after it (the charge counted as the
    replay counts it is kept), the rest as sampled; said in ``notes``."""
    step = int(np.ceil(len(t) / MAX_SAMPLES))
    charge = np.concatenate([[0.0], np.cumsum(i[:-1] * np.diff(t))])
    picked = np.arange(0, len(t), step)
    span = np.diff(t[picked])
    current = np.concatenate([np.diff(charge[picked]) / np.where(span > 0, span, 1.0), [i[picked[-1]]]])
    notes.append('NOTE: decimated: %d samples thinned to every %dth (%d), the current averaged over each new '
                 'interval (the charge kept): every figure is the thinned log\'s' % (len(t), step, len(picked)))
    return t[picked], v[picked], current, temp[picked], pct[picked]


def split_at_gaps(log):
    """The parts of ``log`` between pauses in its samples (a cycler's export, a bag recorded in pieces): what
    happened in a pause is unknown, so each part starts from its own SOC. Parts too short are left out."""
    dt = np.diff(log.time_s)
    threshold = max(GAP_S, GAP_FACTOR * float(np.median(dt)))
    cuts = [0] + [k + 1 for k in np.flatnonzero(dt > threshold)] + [len(log.time_s)]
    if len(cuts) == 2:
        return [log]
    parts, dropped = [], 0
    for number, (start, end) in enumerate(zip(cuts, cuts[1:]), start=1):
        t = log.time_s[start:end]
        if end - start < MIN_SAMPLES or t[-1] - t[0] < MIN_SPAN_S or np.std(log.current_a[start:end]) < MIN_CURRENT_SPREAD_A:
            dropped += 1
            continue
        part = replace(log, name='%s#%d' % (log.name, number), time_s=t - t[0],
                       notes=list(log.notes) + ['part %d of %d between pauses of more than %.0f s (from %.0f s)'
                                                % (number, len(cuts) - 1, threshold, t[0])])
        for name in ('voltage_v', 'current_a', 'temperature_c', 'percentage', 'speed_mean', 'turn_mean',
                     'speed_now', 'turn_now'):
            value = getattr(log, name)
            if value is not None:
                setattr(part, name, value[start:end])
        parts.append(part)
    if not parts:
        raise FitError('%s: every part between its pauses (> %.0f s) is too short or at constant current'
                       % (log.name, threshold))
    if dropped:
        parts[0].notes.append('%d part(s) between pauses too short or at constant current: left out' % dropped)
    return parts


def current_is_inverted(t, v, i):
    """Whether the current is positive while discharging: at a current step the voltage moves with the
    current in ROS's convention (V = E + R I); with no steps, a voltage falling while the current is
    positive says the same."""
    response = step_response(v, i)
    if response is not None:   # the voltage's jump at the step (at its sample or the next, whichever is larger)
        same, following = response
        return (same if abs(same) >= abs(following) else following) < 0.0
    # no steps: the trend of the voltage against the charge counted with this sign
    charge = np.concatenate([[0.0], np.cumsum(0.5 * (i[1:] + i[:-1]) * np.diff(t))])
    if np.ptp(charge) == 0:
        return False
    return float(np.polyfit(charge, v, 1)[0]) < 0.0


def glitches(name, v, i):
    """(current's, voltage's): the samples no battery gives beside the log's others (GLITCH_CURRENT_FACTOR,
    GLITCH_VOLTAGE_RANGE); FitError when more than GLITCH_SHARE of them are so far out."""
    typical_a = max(float(np.percentile(np.abs(i), 99)), MIN_CURRENT_SPREAD_A)
    median_v = float(np.median(v))
    # a current the voltage does not answer: a real pulse (an HPPC test's 10 s at 6C, one sample at 0.1 Hz among
    # hours of rest) moves it by its resistance, a glitch by the sensor's noise
    dv = np.abs(np.diff(v))
    answer_v = np.maximum(np.concatenate([dv, [0.0]]), np.concatenate([[0.0], dv]))
    answer_v = np.maximum(answer_v, np.concatenate([answer_v[1:], [0.0]]))   # the next sample's too
    quiet_v = GLITCH_VOLTAGE_ANSWER * max(float(np.median(dv)) if len(dv) else 0.0, 1e-4 * median_v)
    current_glitch = (np.abs(i) > GLITCH_CURRENT_FACTOR * typical_a) & (answer_v < quiet_v)
    voltage_glitch = (v < GLITCH_VOLTAGE_RANGE[0] * median_v) | (v > GLITCH_VOLTAGE_RANGE[1] * median_v)
    if voltage_glitch.sum() > GLITCH_SHARE * len(v):   # (a current's are at most 1 %: above its 99th percentile)
        raise FitError('%s: %d of %d samples have a voltage outside %g-%g times the median (%.4g V): two batteries, '
                       'or two units, in one log? give one battery\'s log in volts' % (
                           name, voltage_glitch.sum(), len(v), GLITCH_VOLTAGE_RANGE[0], GLITCH_VOLTAGE_RANGE[1],
                           median_v))
    return current_glitch, voltage_glitch


def _refuse_a_restarted_clock(name, t):
    """(Stamps out of order:) FitError where the time goes back far (RESTART_PERIODS) a few times (RESTARTS_AT_MOST) and runs on: a clock
    that restarted (a reboot), whose samples sorted by time would be interleaved, half of them taken for duplicates."""
    steps = np.diff(t)
    back = np.flatnonzero(steps < 0)
    if not back.size or back.size > RESTARTS_AT_MOST:
        return
    forward = steps[steps > 0]
    period = float(np.median(forward)) if forward.size else 0.0
    far = -steps[back] > max(MIN_SPAN_S, RESTART_PERIODS * period)
    if far.any():
        k = back[far][0]
        raise FitError('%s: the time goes back from %.6g s to %.6g s and runs on from there: a clock that restarted '
                       '(a reboot of the robot or the logger)? give the pieces before and after it as logs of their '
                       'own (battery_fit A.csv B.csv ...)' % (name, t[k], t[k + 1]))


def _usable_percentage(t, pct, notes):
    """The logged percentage as 0..1, or None (absent, or not a gauge's: said in ``notes``): 0..100 read as 0..1,
    a value below 0 left out, a column that jumps by more than PERCENTAGE_JUMP between close samples not used."""
    if np.isfinite(pct).sum() < MIN_SAMPLES:
        return None
    negative = pct < 0
    if negative.any():
        notes.append('%d percentages below 0 left out (not a percentage; BatteryState says NaN where unknown)'
                     % negative.sum())
        pct = np.where(negative, np.nan, pct)
        if np.isfinite(pct).sum() < MIN_SAMPLES:
            return None
    scale = 100.0 if np.nanmax(pct) > 1.5 else 1.0
    pct = pct / scale
    finite = np.flatnonzero(np.isfinite(pct))
    jumps = np.abs(np.diff(pct[finite])) * (np.diff(t[finite]) < GAP_S)
    if jumps.size and jumps.max() > PERCENTAGE_JUMP:
        largest = int(np.argmax(jumps))
        before, after = finite[largest], finite[largest + 1]
        notes.append('WARNING: the percentage jumps from %.4g to %.4g (as logged) between two samples %.3g s apart: '
                     'two scales (0-1 and 0-100) or two batteries in one column? not used' % (
                         scale * pct[before], scale * pct[after], t[after] - t[before]))
        return None
    notes.append('percentage: %s' % ('0-100, read as 0-1' if scale == 100.0 else '0-1 (as BatteryState)'))
    return pct


def _filled(values):
    """NaN gaps filled from the neighbours (the temperature of a few missing samples)."""
    good = np.isfinite(values)
    index = np.arange(len(values))
    return np.interp(index, index[good], values[good])


def _motion_at_samples(log, raw, t_abs, timeout_s):
    """|v| and |w| at each battery sample: the latest command (within its timeout) and the mean over the
    interval before the sample (the energy the simulator accounts for between two updates)."""
    mt = np.asarray(raw.motion_time_s, dtype=float)
    order = np.argsort(mt, kind='stable')
    mt = mt[order]
    speed = np.abs(np.asarray(raw.linear_mps, dtype=float))[order]
    turn = np.abs(np.asarray(raw.angular_radps, dtype=float))[order]
    good = np.isfinite(mt) & np.isfinite(speed) & np.isfinite(turn)
    mt, speed, turn = mt[good], speed[good], turn[good]
    if len(mt) == 0:
        return
    # A held command: speed[k] from mt[k] until min(mt[k+1], mt[k] + timeout).
    ends = np.minimum(np.concatenate([mt[1:], [np.inf]]), mt + timeout_s)
    # A piecewise-constant signal on the breakpoints (starts and ends), integrated exactly.
    points = np.unique(np.concatenate([mt, ends[np.isfinite(ends)], t_abs]))
    segment = np.searchsorted(mt, points, side='right') - 1
    held = (segment >= 0) & (points < ends[np.maximum(segment, 0)])
    seg_speed = np.where(held, speed[np.maximum(segment, 0)], 0.0)
    seg_turn = np.where(held, turn[np.maximum(segment, 0)], 0.0)
    widths = np.diff(points)
    cum_speed = np.concatenate([[0.0], np.cumsum(seg_speed[:-1] * widths)])
    cum_turn = np.concatenate([[0.0], np.cumsum(seg_turn[:-1] * widths)])
    at = np.searchsorted(points, t_abs)
    span = np.diff(t_abs)
    log.speed_mean = np.concatenate([[0.0], np.diff(cum_speed[at]) / span])
    log.turn_mean = np.concatenate([[0.0], np.diff(cum_turn[at]) / span])
    now = np.searchsorted(mt, t_abs, side='right') - 1
    fresh = (now >= 0) & (t_abs - mt[np.maximum(now, 0)] <= timeout_s)
    log.speed_now = np.where(fresh, speed[np.maximum(now, 0)], 0.0)
    log.turn_now = np.where(fresh, turn[np.maximum(now, 0)], 0.0)
