"""What a plan of loads, and a charge after it, would do to a battery (no rospy).

A task allocator asks before it assigns: will this robot finish the task, and
how long until it can take the next one? ``predict`` answers from a copy of a
BatteryModel, which it never changes: the same model, protection and CC-CV
charger as the running battery, so the answer agrees with what the battery
then does. The service ``battery_simulator/predict`` and ``battery_replay.py
--charge`` both use it.

A plan is a list of Segments. Each runs with the load connected (discharging)
and adds its current, its power and the motion power of its speed and turn
rate (as cmd_vel does) to the model's base load and its other named loads
(the payloads). Steps are as long as the model allows: a constant current is
exact over any step, so it is stepped in CURRENT_STEP_S pieces; a power load
is solved at the start of each step, so each step moves the charge by at most
POWER_STEP_CHARGE of the capacity; the charger's CV taper is stepped in
CV_STEP_S pieces.
"""
import copy
import math
from dataclasses import dataclass

from battery_simulator.core.battery_model import CutOff, Mode, Status
from battery_simulator.core.parameters import MAX_SPEED_MPS, MAX_TURN_RADPS, is_number, load_power_error

#: the longest plan, s (7 days)
MAX_PLAN_S = 7 * 86400.0
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
#: the request's arrays, in the order of Predict.srv
FIELDS = ('duration_s', 'current_a', 'power_w', 'speed_mps', 'turn_radps')


class PredictionError(ValueError):
    """A plan that cannot be predicted; the message names the field, the value and what is allowed."""


@dataclass(frozen=True)
class Segment:
    """One part of a plan: loads held for ``duration_s`` on top of the base load and the payloads."""

    duration_s: float
    current_a: float = 0.0    # A drawn, >= 0
    power_w: float = 0.0      # W drawn, >= 0
    speed_mps: float = 0.0    # motion load as cmd_vel's |linear.x|
    turn_radps: float = 0.0   # motion load as cmd_vel's |angular.z|


@dataclass(frozen=True)
class Prediction:
    """The answer; ``end_*`` at the end of the segments (before any charge)."""

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


def plan_from_arrays(duration_s=(), current_a=(), power_w=(), speed_mps=(), turn_radps=()):
    """Segments from Predict.srv's arrays: one length, an empty array counting as zeros.

    Raises PredictionError naming the first bad field and index.
    """
    arrays = dict(zip(FIELDS, (duration_s, current_a, power_w, speed_mps, turn_radps)))
    given = [(name, len(values)) for name, values in arrays.items() if len(values)]
    if any(length != given[0][1] for _, length in given):
        raise PredictionError('%s has %d entries but %s has %d: the arrays must have one length (an empty '
                              'array counts as zeros)' % (next((n, k) for n, k in given if k != given[0][1])
                                                          + given[0]))
    count = given[0][1] if given else 0
    rules = {'duration_s': (lambda v: v >= 0.0, 'a number of seconds >= 0'),
             'current_a': (lambda v: v >= 0.0, 'a number of amperes >= 0 (a load)'),
             'power_w': (lambda v: v >= 0.0, 'a number of watts >= 0 (a load)'),
             'speed_mps': (lambda v: abs(v) <= MAX_SPEED_MPS, 'a number in [-%g, %g] m/s' % (MAX_SPEED_MPS,
                                                                                            MAX_SPEED_MPS)),
             'turn_radps': (lambda v: abs(v) <= MAX_TURN_RADPS, 'a number in [-%g, %g] rad/s' % (MAX_TURN_RADPS,
                                                                                               MAX_TURN_RADPS))}
    for name, values in arrays.items():
        check, allowed = rules[name]
        for index, value in enumerate(values):
            if not (is_number(value) and check(value)):
                raise PredictionError('%s[%d] = %r is invalid: must be %s' % (name, index, value, allowed))
    total_s = math.fsum(duration_s)
    if total_s > MAX_PLAN_S:
        raise PredictionError('duration_s totals %g s, which is invalid: a plan is at most %g s (7 days)'
                              % (total_s, MAX_PLAN_S))
    return tuple(Segment(*(float(arrays[name][k]) if arrays[name] else 0.0 for name in FIELDS))
                 for k in range(count))


def check_plan(model, segments, charge_to_percentage=math.nan):
    """Raise PredictionError if a segment's load is beyond what ``model``'s pack can deliver (with its
    base load and its named loads), or ``charge_to_percentage`` is neither NaN nor in [0, 100]."""
    if not (math.isnan(charge_to_percentage) or 0.0 <= charge_to_percentage <= 100.0):
        raise PredictionError('charge_to_percentage = %r is invalid: must be in [0, 100] %% (NaN: no charge)'
                              % (charge_to_percentage,))
    params = model.params
    base_current_a, limit_a = params.load_current_a, params.max_discharge_current_a
    others_w = params.load_power_w + model.extra_power_w
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


def predict(model, segments, charge_to_percentage=math.nan, observe=None):
    """What ``segments`` (then a charge to ``charge_to_percentage``, unless NaN) would do to ``model``.

    ``model`` is not changed (the prediction runs on a copy of it). ``observe(time_s, model)``, if
    given, sees the copy at the start and after every step. Raises PredictionError for a bad plan.
    """
    segments = tuple(segments)
    check_plan(model, segments, charge_to_percentage)
    run = _Run(copy.deepcopy(model), observe)
    for segment in _merged(segments):
        run.discharge(segment)
    end = run.model.snapshot()
    charge_time_s = math.nan if math.isnan(charge_to_percentage) else run.charge(charge_to_percentage)
    return Prediction(feasible=math.isnan(run.cut_off_at_s), end_percentage=end.percentage,
                      end_voltage_v=end.voltage_v, min_voltage_v=run.min_voltage_v,
                      max_temperature_c=run.max_temperature_c, cut_off_at_s=run.cut_off_at_s,
                      charge_time_s=charge_time_s)


def _merged(segments):
    """The plan with empty segments left out and neighbours of the same load joined (3600 one-second
    segments of one load are one step of an hour, not 3600 steps)."""
    merged = []
    for segment in segments:
        if segment.duration_s <= 0.0:
            continue
        if merged and tuple(merged[-1][1:]) == (segment.current_a, segment.power_w, abs(segment.speed_mps),
                                         abs(segment.turn_radps)):
            merged[-1][0] += segment.duration_s
        else:
            merged.append([segment.duration_s, segment.current_a, segment.power_w, abs(segment.speed_mps),
                           abs(segment.turn_radps)])
    return [Segment(*values) for values in merged]


class _Run:
    """One prediction: the copied model, the time from now, and the extremes seen."""

    def __init__(self, model, observe):
        self.model = model
        self.time_s = 0.0
        self.min_voltage_v = model.voltage_v
        self.max_temperature_c = model.temperature_c
        self.cut_off_at_s = math.nan
        self._observe = observe or (lambda time_s, model: None)
        self._observe(0.0, model)

    def discharge(self, segment):
        model, params = self.model, self.model.params
        model.set_mode(Mode.DISCHARGE)
        model.set_extra_load(PLAN_LOAD, current_a=segment.current_a,
                             power_w=segment.power_w + params.motion_power_w(segment.speed_mps, segment.turn_radps))
        constant_current = params.load_power_w + model.extra_power_w == 0.0
        left_s = segment.duration_s
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
        """Seconds from the end of the segments to ``target_percentage`` (inf: never), the charger connected."""
        model, params = self.model, self.model.params
        model.set_extra_load(PLAN_LOAD)
        model.set_mode(Mode.CHARGE)
        start_s = self.time_s
        while self.time_s - start_s < MAX_CHARGE_S:
            model.step(0.0)   # the current held over the next step (the CV taper's end is found here)
            self._seen()
            if self._reached(target_percentage):
                if model.status is Status.FULL:
                    self._observe(self.time_s, model)   # the moment it turned FULL
                return self.time_s - start_s
            if model.charger_fault:
                return math.inf
            near_cv = model.status is Status.CHARGING and (
                model.current_a < 0.999 * params.charge_current_a
                or model.cell_voltage_v > params.cell_charge_voltage_v - CV_ONSET_MARGIN_V)
            step_s = CV_STEP_S if near_cv else self._charge_step()
            before = 100.0 * model.state_of_charge
            model.step(step_s)
            self._advance(step_s)
            if self._reached(target_percentage):
                after = 100.0 * model.state_of_charge
                if model.status is Status.FULL or after <= before:   # the taper ended within this step
                    return self.time_s - start_s
                # the current is held over a step: the level rises linearly within it
                return self.time_s - start_s - step_s * (after - target_percentage) / (after - before)
        return math.inf

    def _charge_step(self):
        model = self.model
        if model.current_a <= 0.0:   # no current (over-temperature): wait for the pack to cool
            return CURRENT_STEP_S
        step_s = CC_STEP_CHARGE * model.capacity_ah * 3600.0 / model.current_a
        return min(max(step_s, CV_STEP_S), CURRENT_STEP_S)

    def _reached(self, target_percentage):
        return self.model.status is Status.FULL or 100.0 * self.model.state_of_charge >= target_percentage

    def _advance(self, step_s):
        self.time_s += step_s
        self._seen()
        self._observe(self.time_s, self.model)

    def _seen(self):
        self.min_voltage_v = min(self.min_voltage_v, self.model.voltage_v)
        self.max_temperature_c = max(self.max_temperature_c, self.model.temperature_c)
