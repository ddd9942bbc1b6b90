"""What a plan of loads, and a charge after it, would do to a battery (no rospy).

A task allocator asks before it assigns: will this robot finish the task, and
how long until it can take the next one? ``predict`` answers from a copy of a
BatteryModel, which it never changes: the same model, protection and CC-CV
charger as the running battery, so the answer agrees with what the battery
then does. The service ``battery_simulator/predict`` and ``battery_replay.py
--charge`` both use it. Its levels are what a robot reads (Part 5): the fuel
gauge's percentage, which the copy's gauge counts as the running one does.

A plan is a list of Segments. Each runs with the load connected (discharging)
and adds its current, its power and the motion power of its speed and turn
rate (as cmd_vel does) to the model's base load and its other named loads
(the payloads). Steps are as long as the model allows: a constant current is
exact over any step, so it is stepped in CURRENT_STEP_S pieces; a power load
is solved at the start of each step, so each step moves the charge by at most
POWER_STEP_CHARGE of the capacity; the charger's CV taper is stepped in
CV_STEP_S pieces.

A plan of many short segments (3600 different one-second loads in an hour)
takes one model step per segment: a segment no longer than MIN_STEP_S, or of
a constant current, needs no look at its current before its step, so it is
stepped at once (the fast way, 5-6 us a segment). The first cut-off found
that way is redone exactly: the plan goes back to a copy of the model taken
at most CHECKPOINT_SEGMENTS segments before, and steps those segments as
above, looking at the current before each step.
"""
import math
import pickle
from dataclasses import dataclass
from itertools import repeat
from typing import NamedTuple

from battery_simulator.core.battery_record import gauge_summary, reported_status
from battery_simulator.core.battery_states import CutOff, Mode, Status
from battery_simulator.core.parameter_rules import MAX_SPEED_MPS, MAX_TURN_RADPS, is_number, load_power_error

#: the longest plan, s (7 days)
MAX_PLAN_S = 7 * 86400.0
#: the most segments a plan may have: a day at one-second resolution (86,400), a week at 10 s (60,480);
#: a plan that long costs about 0.6 s of CPU (in the prediction worker process, not the battery's)
MAX_SEGMENTS = 100_000
#: the fast way keeps a copy of the model every this many segments, to redo its first cut-off exactly
CHECKPOINT_SEGMENTS = 128
#: the plan's load among the model's named loads
PLAN_LOAD = 'prediction'
#: the longest step: a constant current is exact over any step, and this keeps heating and resistance coupled
CURRENT_STEP_S = 600.0
#: a power load's step moves the charge by at most this fraction of the capacity (0.02 pp off at 1 s steps)
POWER_STEP_CHARGE = 0.0025
#: the shortest power-load step, s
MIN_STEP_S = 1.0
#: charging steps: a constant-current step moves the charge by at most this fraction of the capacity
#: (exact at any length); the CV taper is stepped in CV_STEP_S, and its end (FULL) found to within one
CC_STEP_CHARGE = 0.005
CV_STEP_S = 5.0
#: CV steps from this far below the charge voltage (per cell), so that no long step straddles the CV onset
CV_ONSET_MARGIN_V = 0.02
#: a charge that has not reached its level after this long never will
MAX_CHARGE_S = 7 * 86400.0
#: a gauge that has not seen its own end of charge this long after the charger's never will (a learning
#: gauge's takes its taper windows: 80 s by default)
GAUGE_FULL_WAIT_S = 3600.0
#: the request's arrays, in the order of Predict.srv
FIELDS = ('duration_s', 'current_a', 'power_w', 'speed_mps', 'turn_radps')


class PredictionError(ValueError):
    """A plan that cannot be predicted; the message names the field, the value and what is allowed."""


class Segment(NamedTuple):
    """One part of a plan: loads held for ``duration_s`` on top of the base load and the payloads."""

    duration_s: float
    current_a: float = 0.0    # A drawn, >= 0
    power_w: float = 0.0      # W drawn, >= 0
    speed_mps: float = 0.0    # motion load as cmd_vel's |linear.x|
    turn_radps: float = 0.0   # motion load as cmd_vel's |angular.z|


@dataclass(frozen=True)
class Prediction:
    """The answer; ``end_*`` at the end of the segments (before any charge); percentages are the fuel
    gauge's (what the robot reads: the truth with an ideal gauge)."""

    feasible: bool             # the segments end without a cut-off
    end_percentage: float
    end_voltage_v: float
    min_voltage_v: float       # over the segments and the charge
    max_temperature_c: float
    cut_off_at_s: float        # from now, NaN when none
    charge_time_s: float       # after the segments, NaN when not asked, inf when never

    def summary(self):
        """One line for people: where the plan ends and how long the charge takes."""
        text = '%s at %.1f %% (%.2f V, lowest %.2f V, hottest %.1f degC)' % (
            'ends' if self.feasible else 'cut off at %.0f s, ends' % self.cut_off_at_s, self.end_percentage,
            self.end_voltage_v, self.min_voltage_v, self.max_temperature_c)
        if math.isinf(self.charge_time_s):
            text += '; the charge never reaches its level (no charge current)'
        elif not math.isnan(self.charge_time_s):
            text += '; charged in %.0f s (%s)' % (self.charge_time_s, _hours_minutes(self.charge_time_s))
        return text


def _hours_minutes(seconds):
    minutes = int(round(seconds / 60.0))
    return '%d h %02d min' % divmod(minutes, 60)


def too_many_segments(field, count):
    """The refusal of an array of ``count`` entries (more than MAX_SEGMENTS)."""
    return ('%s has %d entries, which is invalid: a plan has at most %d segments (a day at one-second '
            'resolution)' % (field, count, MAX_SEGMENTS))


def plan_from_arrays(duration_s=(), current_a=(), power_w=(), speed_mps=(), turn_radps=()):
    """Segments from Predict.srv's arrays: one length (at most MAX_SEGMENTS), an empty array counting as zeros.

    Raises PredictionError naming the first bad field and index.
    """
    columns = (duration_s, current_a, power_w, speed_mps, turn_radps)
    for name, values in zip(FIELDS, columns):
        if len(values) > MAX_SEGMENTS:
            raise PredictionError(too_many_segments(name, len(values)))
    given = [(name, len(values)) for name, values in zip(FIELDS, columns) if len(values)]
    if any(length != given[0][1] for _, length in given):
        raise PredictionError('%s has %d entries but %s has %d: the arrays must have one length (an empty '
                              'array counts as zeros)' % (next((n, k) for n, k in given if k != given[0][1])
                                                          + given[0]))
    count = given[0][1] if given else 0
    floats = []
    for name, values in zip(FIELDS, columns):
        if not len(values):
            floats.append(repeat(0.0, count))
            continue
        all_floats = set(map(type, values)) <= {float}
        if not (all_floats and _quick_valid(name, values)):
            _check_each(name, values)
        floats.append(values if all_floats else [float(v) for v in values])
    _check_total(duration_s)
    return tuple(map(Segment, *floats))


def _check_total(duration_s):
    try:
        total_s = math.fsum(duration_s)
    except OverflowError:
        total_s = math.inf
    if total_s > MAX_PLAN_S:
        raise PredictionError('duration_s totals %s s, which is invalid: a plan is at most %s s (7 days)'
                              % (_exact(total_s), _exact(MAX_PLAN_S)))


def _check_segments(segments):
    """Raise PredictionError naming the first bad value of ``segments`` given to predict() itself, by the rules
    of Predict.srv's arrays (plan_from_arrays)."""
    if not segments:
        return
    for name, values in zip(FIELDS, zip(*segments)):
        if not (set(map(type, values)) <= {float, int} and _quick_valid(name, values)):
            _check_each(name, values)
    _check_total(segment.duration_s for segment in segments)


#: each array's rule: a test of one value, and what is allowed
_RULES = {'duration_s': (lambda v: v >= 0.0, 'a number of seconds >= 0'),
          'current_a': (lambda v: v >= 0.0, 'a number of amperes >= 0 (a load)'),
          'power_w': (lambda v: v >= 0.0, 'a number of watts >= 0 (a load)'),
          'speed_mps': (lambda v: abs(v) <= MAX_SPEED_MPS, 'a number in [-%g, %g] m/s' % (MAX_SPEED_MPS,
                                                                                         MAX_SPEED_MPS)),
          'turn_radps': (lambda v: abs(v) <= MAX_TURN_RADPS, 'a number in [-%g, %g] rad/s' % (MAX_TURN_RADPS,
                                                                                            MAX_TURN_RADPS))}
#: the bound of each motion array (either sign)
_MOTION_LIMITS = {'speed_mps': MAX_SPEED_MPS, 'turn_radps': MAX_TURN_RADPS}


def _quick_valid(name, values):
    """Whether every value (all floats) keeps its array's rule, in a few passes at C speed."""
    if not math.isfinite(sum(values)):   # a NaN or an infinity (or a sum beyond floats: checked one by one)
        return False
    if name in _MOTION_LIMITS:
        return max(map(abs, values)) <= _MOTION_LIMITS[name]
    return min(values) >= 0.0


def _check_each(name, values):
    """Raise PredictionError naming the first value of ``name`` that breaks its rule."""
    check, allowed = _RULES[name]
    for index, value in enumerate(values):
        if not (is_number(value) and check(value)):
            raise PredictionError('%s[%d] = %r is invalid: must be %s' % (name, index, value, allowed))


def _exact(value):
    """A number of seconds as it is: whole ones without a decimal point, others to the last digit (no %g rounding)."""
    if value.is_integer() and abs(value) < 1e16:
        return '%d' % value
    return repr(value)


def check_plan(model, segments, charge_to_percentage=math.nan):
    """Raise PredictionError if a segment's load is beyond what ``model``'s pack can deliver (with its
    base load and its named loads), or ``charge_to_percentage`` is neither NaN nor in [0, 100]."""
    if not (math.isnan(charge_to_percentage) or 0.0 <= charge_to_percentage <= 100.0):
        raise PredictionError('charge_to_percentage = %r is invalid: must be in [0, 100] %% (0 or NaN: no charge)'
                              % (charge_to_percentage,))
    _check_segments(segments)
    params = model.params
    base_current_a, limit_a = params.load_current_a, params.max_discharge_current_a
    others_w = params.load_power_w + model.extra_power_w
    if segments:   # all at once first; one by one (naming the first bad segment) only if one is beyond
        drive, turn = params.drive_power_w_per_mps, params.turn_power_w_per_radps
        powers_w = [power + drive * abs(speed) + turn * abs(rate) for _, _, power, speed, rate in segments]
        most_w, limit_w = max(powers_w), params.max_discharge_power_w
        if max(segment[1] for segment in segments) + base_current_a <= limit_a and math.isfinite(sum(powers_w)) \
                and min(powers_w) >= 0.0 and most_w <= limit_w and most_w + others_w <= limit_w:
            return
    for index, segment in enumerate(segments):
        if segment.current_a + base_current_a > limit_a:
            raise PredictionError('current_a[%d] = %r is invalid: must be in [0, %g] A (with the base load of %g A, '
                                  'at most the %g A the pack can deliver)' % (
                                      index, segment.current_a, limit_a - base_current_a, base_current_a, limit_a))
        motion_w = params.motion_power_w(segment.speed_mps, segment.turn_radps)
        field = 'power_w[%d]' % index
        if motion_w:
            field += ' + the motion of speed_mps[%d] and turn_radps[%d]' % (index, index)
        power_w = segment.power_w + motion_w
        error = load_power_error(params, field, power_w, power_w + others_w,
                                 'with the base load and the payloads (%g W) it' % others_w)
        if error:
            raise PredictionError(error)


def predict(model, segments, charge_to_percentage=math.nan, observe=None, until_full=False):
    """What ``segments`` (then a charge to ``charge_to_percentage``, unless NaN or 0) would do to ``model``.

    Levels are the fuel gauge's (what a robot reads; the truth with an ideal gauge): ``end_percentage``,
    and the charge ends when the gauge reads ``charge_to_percentage`` or the pack is Full, whichever first.
    ``until_full``: the charge ends at Full only (battery_replay.py --charge): the charger's, whatever a counter
    reads; observed on to a learning gauge's own end of charge (GAUGE_FULL_WAIT_S at most), its time the charger's.
    ``model`` is not changed (the prediction runs on a copy of it). ``observe(time_s, model)``, if
    given, sees the copy at the start and after every step. Raises PredictionError for a bad plan.
    """
    segments = tuple(segments)
    if until_full:
        charge_to_percentage = math.inf
    elif charge_to_percentage == 0.0:   # a ROS message's default: no charge, as NaN
        charge_to_percentage = math.nan
    check_plan(model, segments, 100.0 if until_full else charge_to_percentage)
    run = _Run(_copy(model), observe)
    run.discharge_plan(_merged(segments, model.params))
    end = run.model.snapshot()
    charge_time_s = math.nan if math.isnan(charge_to_percentage) else run.charge(charge_to_percentage)
    return Prediction(feasible=math.isnan(run.cut_off_at_s), end_percentage=end.percentage,
                      end_voltage_v=end.voltage_v, min_voltage_v=run.min_voltage_v,
                      max_temperature_c=run.max_temperature_c, cut_off_at_s=run.cut_off_at_s,
                      charge_time_s=charge_time_s)


def _reads_full(model):
    """Whether battery_status says FULL: the charger's end, or a learning gauge's own (core/battery_record.py)."""
    return reported_status(model.status, gauge_summary(model).full) is Status.FULL


def _level(model):
    """The percentage a robot reads: the fuel gauge's (the truth with an ideal gauge), as end_percentage."""
    return model.gauge_reading()[0]


def _copy(model):
    """A copy of ``model`` (through pickle: the same as copy.deepcopy, in a quarter of the time)."""
    return pickle.loads(pickle.dumps(model, pickle.HIGHEST_PROTOCOL))


def _merged(segments, params):
    """The plan as (duration_s, current_a, power_w) loads, the motion in the power, with empty segments left
    out and neighbours of the same load joined (3600 one-second segments of one load are one step of an
    hour, not 3600 steps)."""
    merged = []
    drive, turn = params.drive_power_w_per_mps, params.turn_power_w_per_radps
    last = None
    for duration_s, current_a, power_w, speed_mps, turn_radps in segments:
        if duration_s <= 0.0:
            continue
        load = (current_a, power_w + drive * abs(speed_mps) + turn * abs(turn_radps))
        if load == last:
            merged[-1][0] += duration_s
        else:
            merged.append([duration_s, *load])
            last = load
    return merged


class _Run:
    """One prediction: the copied model, the time from now, and the extremes seen."""

    def __init__(self, model, observe):
        self.model = model
        self.time_s = 0.0
        self.min_voltage_v = model.voltage_v
        self.max_temperature_c = model.temperature_c
        self.cut_off_at_s = math.nan
        self._others_w = 0.0
        self._observed = observe is not None
        self._observe = observe or (lambda time_s, model: None)
        self._observe(0.0, model)

    def discharge_plan(self, plan):
        """Each (duration_s, current_a, power_w) load in turn: in one step each where that needs no look at
        the current first (_fast), else in steps chosen from the current (discharge)."""
        if not plan:
            return
        self.model.set_mode(Mode.DISCHARGE)
        # the power of the base load and the payloads (the plan's own load is not set yet)
        self._others_w = self.model.params.load_power_w + self.model.extra_power_w
        index = 0
        while index < len(plan):
            if self._observed or not self._one_step(plan[index]):
                self.discharge(plan[index])
                index += 1
            else:
                index = self._fast(plan, index)

    def _one_step(self, load):
        """Whether ``load``'s steps can be chosen without its current: a constant current (the longest
        steps), or a power load no longer than one MIN_STEP_S step."""
        return load[0] <= MIN_STEP_S or (load[2] == 0.0 and self._others_w == 0.0)

    def _fast(self, plan, start):
        """Step the loads from ``plan[start]`` on while _one_step holds, without a look at the current
        before each step; the index of the load after them. Until the first cut-off, a copy of the model is
        kept every CHECKPOINT_SEGMENTS loads: a cut-off is redone from the last one by discharge."""
        model = self.model
        step, set_load, empty, others_w = model.step, model.set_extra_load, Status.EMPTY, self._others_w
        min_voltage_v, max_temperature_c, time_s = self.min_voltage_v, self.max_temperature_c, self.time_s
        watch = math.isnan(self.cut_off_at_s)
        checkpoint = None
        index = start
        for index in range(start, len(plan)):
            duration_s, current_a, power_w = plan[index]
            if duration_s > MIN_STEP_S and (power_w or others_w):
                break
            if watch and (checkpoint is None or index - checkpoint[0] >= CHECKPOINT_SEGMENTS):
                checkpoint = (index, pickle.dumps(model, pickle.HIGHEST_PROTOCOL), time_s, min_voltage_v,
                              max_temperature_c)
            set_load(PLAN_LOAD, current_a, power_w)
            left_s = duration_s
            while left_s > 0.0:
                step_s = left_s if left_s <= CURRENT_STEP_S else CURRENT_STEP_S
                step(step_s)
                time_s += step_s
                left_s -= step_s
                voltage_v, temperature_c = model.voltage_v, model.temperature_c
                if voltage_v < min_voltage_v:
                    min_voltage_v = voltage_v
                if temperature_c > max_temperature_c:
                    max_temperature_c = temperature_c
            if watch and model.status is empty:   # cut off: when, exactly?
                until, (index, blob, self.time_s, self.min_voltage_v, self.max_temperature_c) = index, checkpoint
                self.model = pickle.loads(blob)
                for index in range(index, until + 1):
                    self.discharge(plan[index])
                return until + 1
        else:
            index = len(plan)
        self.min_voltage_v, self.max_temperature_c, self.time_s = min_voltage_v, max_temperature_c, time_s
        return index

    def discharge(self, load):
        duration_s, current_a, power_w = load
        model, params = self.model, self.model.params
        model.set_mode(Mode.DISCHARGE)
        model.set_extra_load(PLAN_LOAD, current_a=current_a, power_w=power_w)
        constant_current = params.load_power_w + model.extra_power_w == 0.0
        left_s = duration_s
        while left_s > 0.0:
            model.step(0.0)   # the current held over the next step (a power load is solved now)
            self._seen()
            if model.status is Status.EMPTY:
                self._cut_off(0.0)
            current_a, discharged_ah = model.cell_current_a, model.discharged_ah
            step_s = min(left_s, self._discharge_step(constant_current))
            model.step(step_s)
            if model.status is Status.EMPTY and current_a < 0.0:   # cut off within this step: when?
                self._cut_off(min(step_s, (model.discharged_ah - discharged_ah) * 3600.0 / -current_a))
            self._advance(step_s)
            left_s -= step_s

    def _discharge_step(self, constant_current):
        model = self.model
        if constant_current or model.cell_current_a == 0.0 or model.cut_off is CutOff.UNDER_VOLTAGE:
            return CURRENT_STEP_S
        step_s = POWER_STEP_CHARGE * model.capacity_ah * 3600.0 / abs(model.current_a)
        return min(max(step_s, MIN_STEP_S), CURRENT_STEP_S)

    def _cut_off(self, within_step_s):
        if not math.isnan(self.cut_off_at_s):
            return
        self.cut_off_at_s = self.time_s + within_step_s
        if self.model.cut_off is CutOff.UNDER_VOLTAGE:   # the loaded voltage at that moment
            params = self.model.params
            self.min_voltage_v = min(self.min_voltage_v, params.cell_cutoff_voltage_v * params.cells_series)

    def charge(self, target_percentage):
        """Seconds from the end of the segments until the gauge reads ``target_percentage`` or the pack is
        Full, whichever first (inf: never), the charger connected. A target of inf: until Full."""
        model, params = self.model, self.model.params
        until_full = math.isinf(target_percentage)
        model.set_extra_load(PLAN_LOAD)
        model.set_mode(Mode.CHARGE)
        start_s = self.time_s
        full_at_s = math.inf   # when the charger ended the charge

        def chargers_time():   # until Full: the charger's Full, wherever the rows (a learning gauge's) end
            return (full_at_s if full_at_s < math.inf else self.time_s) - start_s
        while self.time_s - start_s < MAX_CHARGE_S:
            model.step(0.0)   # the current held over the next step (the CV taper's end is found here)
            self._seen()
            if self._reached(target_percentage):
                if _reads_full(model):
                    self._observe(self.time_s, model)   # the moment it turned FULL
                return chargers_time() if until_full else self.time_s - start_s
            if model.charger_fault:
                return math.inf
            if model.status is Status.FULL and self.time_s - full_at_s > GAUGE_FULL_WAIT_S:
                # the charger has ended, the gauge never will: the robot never reads it (until Full: the charger's)
                return chargers_time() if until_full else math.inf
            # the CV taper, and a gauge's own end of charge after the charger's (a learning gauge's windows)
            near_cv = model.status is Status.FULL or model.status is Status.CHARGING and (
                model.current_a < 0.999 * params.charge_current_a
                or model.cell_voltage_v > params.cell_charge_voltage_v - CV_ONSET_MARGIN_V)
            step_s = CV_STEP_S if near_cv else self._charge_step()
            before = _level(model)
            model.step(step_s)
            self._advance(step_s)
            if model.status is Status.FULL and full_at_s == math.inf:
                full_at_s = self.time_s
            if self._reached(target_percentage):
                if until_full:
                    return chargers_time()
                after = _level(model)
                if _reads_full(model) or after <= before:   # the taper (or the gauge's) ended within this step
                    return self.time_s - start_s
                # the current is held over a step: the level rises linearly within it
                return self.time_s - start_s - step_s * (after - target_percentage) / (after - before)
        return math.inf

    def _charge_step(self):
        model = self.model
        if model.current_a <= 0.0:   # no current (over-temperature): wait for the pack to cool
            return CURRENT_STEP_S
        step_s = CC_STEP_CHARGE * model.capacity_ah * 3600.0 / model.current_a
        # no further than the pack fills (SOC 1: a pack of groups' fullest group, which at a low current fills
        # below the CV onset): its Full found to within a CV step, not at a long step's end
        fills_s = (1.0 - model.state_of_charge) * model.capacity_ah * 3600.0 / (
            model.params.coulombic_efficiency * model.current_a)
        return min(max(min(step_s, fills_s), CV_STEP_S), CURRENT_STEP_S)

    def _reached(self, target_percentage):
        """The charge ends at the level the robot reads (the gauge's), or at Full as the robot reads it (a
        learning gauge's own end of charge, a minute after the charger's); no level (inf, battery_replay
        --charge's until full): at the charger's Full and the gauge's both (its rows show the gauge's 100 %
        and its end_of_charge; the time is the charger's)."""
        model = self.model
        if math.isinf(target_percentage):
            return model.status is Status.FULL and _reads_full(model)
        return _reads_full(model) or _level(model) >= target_percentage

    def _advance(self, step_s):
        self.time_s += step_s
        self._seen()
        self._observe(self.time_s, self.model)

    def _seen(self):
        self.min_voltage_v = min(self.min_voltage_v, self.model.voltage_v)
        self.max_temperature_c = max(self.max_temperature_c, self.model.temperature_c)
