"""One simulated battery's behaviour, ROS-free: what every front end wraps.

``Battery`` holds the model and everything that acts on it: the time base
(wall time scaled, or a simulator's clock), the loads (motion from cmd_vel,
named payloads), the charger contact and the mode with its goal rules, the
test controls (set_state, reset, faults and noise) and the state record the
nodes publish (core/battery_record.py). The rospy server and publisher, the rospy fleet host and the
rclpy nodes only turn its records into messages, its errors into service
replies and their inputs into its calls (as smach_ros wraps smach).

Time and logging come from outside: ``clock()`` returns the front end's
time (monotonic wall seconds, or ROS time under sim time) and ``log`` has
info/warn/error and their ``*_throttle`` forms (ros1/log.py for
rospy, ros2/ for rclpy).

Lock: ``self.lock`` (a Condition on an RLock) guards the model and all of
this object's state. Every public method takes it; a front end may hold it
around several calls (a service's change and its wait for the publication).
"""
import copy
import math
import pickle
import random
import threading
import time
from dataclasses import replace

from battery_simulator.core.battery_record import BatteryRecord, gauge_summary
from battery_simulator.core.battery_states import CutOff, Mode, Status
from battery_simulator.core.gauge import CAPACITY_LEARNED, LOGGED_CORRECTION
from battery_simulator.core.node_settings import (MODE_ALLOWED, SettingError, check_setting, is_mode_value, refusal,
                                                  setting)
from battery_simulator.core.pack import make_model
from battery_simulator.core.parameter_rules import (MAX_SPEED_MPS, MAX_TURN_RADPS, ParameterError, is_number,
                                                    load_power_error)
from battery_simulator.core.status_codes import EMPTY, FAULTS, FULL
from battery_simulator.core.time_base import TimeBase

#: under sim time, the largest forward step of ROS time between two updates that counts as elapsed, s.
#: The fastest honest clock here is sim_clock at speed 1000 (demo.launch documents up to 960): 100 s
#: between two 10 Hz updates, 1000 s if the process stalls for a second; a second /clock publisher
#: interleaving its times jumps by hours (48,000 s measured). One hour leaves a 3.6 s stall at speed 1000.
DEFAULT_MAX_TIME_JUMP_S = 3600.0
OVERHEAT_MARGIN_K = 2.0   # the overheat fault holds the pack this far above its overheat limit
INVALID_LOG_PERIOD_S = 10.0
#: the live (dynamic_reconfigure / ros2 param) keys that are battery parameters (time_scale is the battery's own)
LIVE_PARAMETERS = ('load_current_a', 'load_power_w', 'charge_current_a', 'ambient_temperature_c',
                   'drive_power_w_per_mps', 'turn_power_w_per_radps')
#: the model's named loads: cmd_vel's motion, set_load's payloads
MOTION_LOAD = 'motion'
PAYLOAD_LOAD = 'payload'
#: a mode value that could not be read (the master is gone): the mode stays
UNREADABLE = object()


class BatteryError(ValueError):
    """A request refused, with the reason a service replies (nothing changed)."""


def parse_mode(value):
    """The Mode a mode value (MyRobot/BatteryStatus, ROS 2's ``charging``) asks for, or None if invalid.
    Unset (None) holds: IDLE."""
    if value is None:
        return Mode.IDLE
    if not is_mode_value(value):   # core/node_settings.py's rule of the mode's values (true / false, 1 / 0)
        return None
    return Mode.CHARGE if value == 1 else Mode.DISCHARGE   # True == 1


class Goal:
    """An action goal being pursued: the mode it asked for and where it ends."""

    def __init__(self, charge):
        self.mode = Mode.CHARGE if charge else Mode.DISCHARGE
        self.target = Status.FULL if charge else Status.EMPTY
        self.done_text = FULL if charge else EMPTY


class GoalEnd:
    """How a goal ended: ``outcome`` 'succeeded', 'aborted' or 'preempted', and its battery_status text."""
    SUCCEEDED, ABORTED, PREEMPTED = 'succeeded', 'aborted', 'preempted'

    def __init__(self, outcome, text):
        self.outcome, self.text = outcome, text

    def __repr__(self):
        return 'GoalEnd(%r, %r)' % (self.outcome, self.text)


class Update:
    """What one ``Battery.update()`` did: the record to publish, the state to save, and ``time_jump``:
    None, or 'backwards' / 'forwards' when the clock jumped and the time base restarted."""

    def __init__(self, record, saved_state, now, time_jump=None):
        self.record = record
        self.snapshot = record.snapshot
        self.saved_state = saved_state
        self.now = now
        self.time_jump = time_jump

    def time_jump_warning(self, max_jump_s, clock_publishers=()):
        """The line a front end logs (throttled) after a jump: what happened, and who publishes /clock
        when more than one node does (the usual cause of jumps back and forth)."""
        if self.time_jump == 'backwards':
            text = ('ROS time moved backwards (to %.3f s): time base restarted, nothing drained for the jump'
                    % self.now)
        else:
            text = ('ROS time jumped forwards by more than max_time_jump (%g s) to %.3f s: time base restarted, '
                    'nothing drained' % (max_jump_s, self.now))
        if len(clock_publishers) > 1:
            text += '; /clock has %d publishers: %s (one clock only)' % (len(clock_publishers),
                                                                        ', '.join(sorted(clock_publishers)))
        return text


class Battery:
    """One battery: the model, its loads, mode, goals, controls and faults (see the module's docstring)."""

    def __init__(self, params, initial_percentage=100.0, charging=False, clock=time.monotonic, sim_time=False,
                 time_scale=1.0, mode_name='MyRobot/BatteryStatus', log=None, noise_seed=None,
                 max_time_jump=DEFAULT_MAX_TIME_JUMP_S):
        """``clock()``: the front end's time; ``sim_time``: it is a simulator's clock (0 = not started,
        ``time_scale`` ignored; a forward jump of more than ``max_time_jump`` s between two updates
        restarts the time base); ``mode_name``: what the front end calls the mode (in abort texts)."""
        self.lock = threading.Condition()
        self.mode_name = mode_name
        self.sim_time = sim_time
        self._clock = clock
        self._log = log or _SilentLog()
        self._initial_soc = initial_percentage / 100.0
        self.time_scale = time_scale    # as configured (the time base ignores it under sim time)
        self.max_time_jump = max_time_jump
        self._time_base = TimeBase(1.0, zero_is_unset=True, max_jump_s=max_time_jump, hold_jumps=True) \
            if sim_time else TimeBase(time_scale)
        self.mode_generation = 0        # bumped whenever the mode is set other than by the mode value
        self._mode_source = 'parameter'  # who set the mode last (for abort texts)
        self._contact = False           # the charger contact as last reported
        self._motion = (None, 0.0, 0.0)  # (clock time, |v| m/s, |w| rad/s) of the last cmd_vel
        self._motion_since = None       # clock time the motion energy is accounted up to
        self._motion_energy_j = 0.0     # motion energy since the model's last step, J
        self._payloads = {}             # name -> W
        self._faults = set()
        self._noise = random.Random(noise_seed)
        self._invalid_logged = (None, 0.0)   # (repr of the bad mode value, monotonic time) last logged
        self.model = make_model(params, state_of_charge=self._initial_soc,
                                mode=Mode.CHARGE if charging else Mode.DISCHARGE)

    @property
    def params(self):
        return self.model.params

    @property
    def initial_percentage(self):
        return 100.0 * self._initial_soc

    def resume(self, saved):
        """Resume from a saved state (``export_state()``); ValueError (nothing changed) if it does not fit."""
        with self.lock:
            self.model.restore_state(saved)

    def export_state(self):
        with self.lock:
            return self.model.export_state()

    # -- time and updates --------------------------------------------------------

    def advance_to_now(self):
        """Step the model up to this moment before a change, so that the change does not act on the
        time before it (one update period: 100 s of battery at time x1000, 10 Hz)."""
        with self.lock:
            self._step_to(self._clock())

    def update(self, mode_value=UNREADABLE, generation=None):
        """One model update: follow ``mode_value`` (read by the front end before taking the lock; ignored
        when the mode was set since ``generation``), apply faults, step to now; an Update."""
        with self.lock:   # the clock is read under the lock: a service may step the model to its own now
            now = self._clock()
            back, forward = self._time_base.jumps_back, self._time_base.jumps_forward
            if mode_value is not UNREADABLE and generation in (None, self.mode_generation):
                self.follow_mode_value(mode_value)
            if 'overheat' in self._faults:
                self.model.temperature_c = max(self.model.temperature_c,
                                               self.params.overheat_temperature_c + OVERHEAT_MARGIN_K)
            motion_w = self._step_to(now)
            self._log_gauge_corrections()
            record = BatteryRecord(self.model.snapshot(), self.params, motion_w + sum(self._payloads.values()),
                                   self._faults, self._noise, gauge_summary(self.model))
            jump = 'backwards' if self._time_base.jumps_back != back else \
                'forwards' if self._time_base.jumps_forward != forward else None
            return Update(record, self.model.export_state(), now, jump)

    def record(self):
        """The state now (without stepping), as a record."""
        with self.lock:
            return BatteryRecord(self.model.snapshot(), self.params, sum(self._payloads.values()), self._faults,
                                 self._noise, gauge_summary(self.model))

    def _log_gauge_corrections(self):
        """Each correction of the gauge larger than one point, once: old -> new and why (Part 9)."""
        gauge = self.model.gauge
        if gauge is None:
            return
        for event in gauge.take_events():
            if event.size <= LOGGED_CORRECTION:
                continue
            if event.kind == CAPACITY_LEARNED:
                self._log.info('gauge %s: full capacity %.3f Ah -> %.3f Ah (%s)', event.kind, event.old, event.new,
                               event.reason)
            else:
                self._log.info('gauge %s: %.1f %% -> %.1f %% (%s)', event.kind, event.old, event.new, event.reason)

    def snapshot_now(self):
        with self.lock:
            self.model.step(0.0)
            return self.model.snapshot()

    def _step_to(self, now):
        """Step the model to ``now`` with the motion load it had meanwhile: the energy of every cmd_vel
        over the time it held, so an update period of any length (24 s of ROS time at speed 240)
        drains what the robot's motion took. Returns that average motion power, W."""
        self._account_motion(now)
        dt_s = self._time_base.elapsed(now)
        motion_w = self._motion_energy_j / dt_s if dt_s > 0.0 else self._motion_power_w(now)
        if not self._time_base.holding:   # a held step keeps its motion energy until it counts
            self._motion_energy_j = 0.0
        self.model.set_extra_load(MOTION_LOAD, power_w=motion_w)
        self.model.step(dt_s)
        return motion_w

    def _account_motion(self, now):
        """Add the energy of the command held since the last accounting: a cmd_vel counts from its
        arrival until the next one or until it times out, on the model's clock."""
        stamp, speed, turn = self._motion
        since, self._motion_since = self._motion_since, now
        if stamp is None or since is None or now <= since:
            return   # nothing commanded yet, or the clock jumped back
        held_s = min(now, stamp + self.params.cmd_vel_timeout_s) - max(since, stamp)   # on the clock
        if held_s > 0.0:   # in simulated seconds, as the model steps
            self._motion_energy_j += held_s * self._time_base.time_scale * self.params.motion_power_w(speed, turn)

    def _motion_power_w(self, now):
        """The motion power of the command in force at ``now``, W."""
        stamp, speed, turn = self._motion
        if stamp is None or not 0.0 <= now - stamp <= self.params.cmd_vel_timeout_s:
            return 0.0
        return self.params.motion_power_w(speed, turn)

    # -- the mode ------------------------------------------------------------------

    def follow_mode_value(self, value):
        """Follow the mode value (MyRobot/BatteryStatus, ``charging``): a bad one is logged (throttled)
        and the mode stays. True if the value was valid."""
        mode = parse_mode(value)
        with self.lock:
            if mode is None:
                self._log_invalid_mode(value)
                return False
            self._invalid_logged = (None, 0.0)
            if mode is not self.model.mode:
                self._mode_source = 'parameter'
                self.model.set_mode(mode)
            return True

    def set_mode(self, mode, source):
        """Set the mode other than through the mode value (a goal, the charger contact, set_charging):
        the front end writes the mode value to match."""
        with self.lock:
            self._step_to(self._clock())
            self.mode_generation += 1
            self._mode_source = source
            self.model.set_mode(mode)

    @property
    def mode(self):
        return self.model.mode

    def _log_invalid_mode(self, value):
        """An error at once for each new bad value, then every INVALID_LOG_PERIOD_S while it stays."""
        logged_value, logged_at = self._invalid_logged
        now = time.monotonic()
        if logged_value == repr(value) and now - logged_at < INVALID_LOG_PERIOD_S:
            return
        self._invalid_logged = (repr(value), now)
        self._log.error('%s', refusal(self.mode_name, value, 'must be %s, or unset (hold); keeping %s' % (
            MODE_ALLOWED, self.model.mode.value)))

    # -- goals -----------------------------------------------------------------------

    def goal_end(self, goal, snapshot):
        """The end ``goal`` has reached at ``snapshot`` (a GoalEnd), or None while it runs on."""
        if snapshot.status is goal.target and snapshot.cut_off in (None, CutOff.UNDER_VOLTAGE):
            return GoalEnd(GoalEnd.SUCCEEDED, goal.done_text)
        if snapshot.mode is not goal.mode:
            with self.lock:
                source = self._mode_source
            return GoalEnd(GoalEnd.ABORTED, 'Aborted at %.1f %%: %s was changed to %s (%s) while %s' % (
                snapshot.percentage, self.mode_name, snapshot.mode.value, source, goal.mode.value))
        if snapshot.status is Status.EMPTY:
            return GoalEnd(GoalEnd.ABORTED, 'Aborted at %.1f %%: the pack protection cut the load off (%s)'
                           % (snapshot.percentage, snapshot.cut_off.value))
        return None

    def preempted(self, reason):
        """The GoalEnd of a goal preempted now for ``reason`` (a new goal, a cancel, shutdown)."""
        snapshot = self.snapshot_now()
        return GoalEnd(GoalEnd.PREEMPTED, 'Preempted at %.1f %% (%s, %s)' % (
            snapshot.percentage, reason, snapshot.status.value))

    # -- inputs ----------------------------------------------------------------------

    def on_cmd_vel(self, linear_x, angular_z):
        """A velocity command (motion load while discharging); BatteryError beyond what a robot can do."""
        speed, turn = abs(linear_x), abs(angular_z)
        if not (speed <= MAX_SPEED_MPS and turn <= MAX_TURN_RADPS):   # also NaN
            raise BatteryError('ignoring a cmd_vel beyond what a robot can do (|linear.x| %r m/s, |angular.z| %r '
                               'rad/s; at most %g and %g)' % (speed, turn, MAX_SPEED_MPS, MAX_TURN_RADPS))
        with self.lock:
            now = self._clock()
            self._account_motion(now)   # the previous command's energy up to now
            self._motion = (now, speed, turn)

    def take_cmd_vel(self, twist):
        """A cmd_vel's twist as both front ends take it: on_cmd_vel, a command it refuses logged (at most every
        INVALID_LOG_PERIOD_S) and dropped: the sender is not told, and the motion in force stays."""
        try:
            self.on_cmd_vel(twist.linear.x, twist.angular.z)
        except BatteryError as error:
            self._log.error_throttle(INVALID_LOG_PERIOD_S, '%s', error)

    def change_contact(self, connected, source):
        """A charger contact report: only a change acts (connected -> charge, disconnected -> discharge).
        True if it changed the mode (the front end writes the mode value)."""
        with self.lock:
            changed, self._contact = connected != self._contact, connected
            if changed:
                self.set_mode(Mode.CHARGE if connected else Mode.DISCHARGE, source)
        return changed

    def set_load(self, name, power_w):
        """Set (0: remove) a named payload load; the reply's text, or BatteryError."""
        name = name.strip() if isinstance(name, str) else ''
        if not name:
            raise BatteryError('name must not be empty')
        error = load_power_error(self.params, 'power_w', power_w, power_w, 'it')
        if error:
            raise BatteryError(error)
        with self.lock:
            total_w = sum(p for n, p in self._payloads.items() if n != name) + power_w
            error = load_power_error(self.params, 'power_w', power_w, total_w, 'the payload loads')
            if error:
                raise BatteryError(error)
            if power_w > 0.0:
                self._payloads[name] = power_w
            else:
                self._payloads.pop(name, None)
            total = sum(self._payloads.values())
            self.model.set_extra_load(PAYLOAD_LOAD, power_w=total)
        return '%s: %g W; payload loads now %g W' % (name, power_w, total)

    def set_state(self, percentage=math.nan, temperature_c=math.nan, state_of_health=math.nan, gauge_error=math.nan):
        """Put the pack where a test needs it (NaN or None leaves a value; a gauge_error of 0 adds nothing);
        the reply's text, or BatteryError."""
        def given(value):
            return None if value is None or (isinstance(value, float) and math.isnan(value)) else value
        percentage = given(percentage)
        if percentage is not None and not (is_number(percentage) and 0.0 <= percentage <= 100.0):
            raise BatteryError('percentage = %r is invalid: must be in [0, 100] %%' % (percentage,))
        gauge_error = None if given(gauge_error) in (None, 0, 0.0) else gauge_error
        try:
            with self.lock:
                self.model.set_state(None if percentage is None else percentage / 100.0,
                                     given(temperature_c), given(state_of_health), gauge_error)
        except (ValueError, TypeError) as error:
            raise BatteryError(str(error)) from None
        return 'state set'

    def reset(self):
        """Back to the configured start exactly (level, the groups' offsets, the gauge's initial error,
        temperature, health, cycle count, no faults): a new model as at start-up, with the mode and the
        named loads kept. The reply's text."""
        with self.lock:
            self._step_to(self._clock())   # the time so far belongs to the old model
            old = self.model
            self.model = make_model(old.params, state_of_charge=self._initial_soc, mode=old.mode)
            for name, (current_a, power_w) in old.extra_loads().items():
                self.model.set_extra_load(name, current_a, power_w)
            cleared, self._faults = sorted(self._faults), set()   # the start-up state has no faults
        if cleared:
            self._log.warn('reset: faults cleared: %s', ', '.join(cleared))
        return 'reset to %.1f %%, mode kept%s' % (
            100.0 * self._initial_soc, '; faults cleared: ' + ', '.join(cleared) if cleared else '')

    def inject_fault(self, fault, active):
        """Turn a fault on or off; the reply's text, or BatteryError (an unknown fault lists the known ones)."""
        if fault not in FAULTS:
            raise BatteryError('unknown fault %r; known faults: %s' % (
                fault, '; '.join('%s (%s)' % item for item in sorted(FAULTS.items()))))
        with self.lock:
            if active:
                self._faults.add(fault)
            else:
                self._faults.discard(fault)
            if fault == 'charger_fault':
                self.model.set_charger_fault(active)
            elif fault == 'gauge_stuck':
                self.model.set_gauge_stuck(active)
        self._log.warn('fault %s %s', fault, 'injected' if active else 'cleared')
        return '%s %s' % (fault, 'active' if active else 'cleared')

    @property
    def faults(self):
        with self.lock:
            return frozenset(self._faults)

    def model_for_prediction(self):
        """A copy of the model brought to now at its present loads, the motion load removed (a plan's
        motion takes the place of cmd_vel's); the battery itself is not changed."""
        with self.lock:
            model = copy.deepcopy(self.model)
            behind_s = self._time_base.pending(self._clock())
        model.step(behind_s)
        model.set_extra_load(MOTION_LOAD)
        return model

    def model_for_prediction_pickled(self):
        """(the pickled model as it is, the seconds it is behind now): what a prediction worker process
        needs to bring a copy to now (prediction_service.py); taken under the lock, cheap."""
        with self.lock:
            return pickle.dumps(self.model, pickle.HIGHEST_PROTOCOL), self._time_base.pending(self._clock())

    # -- live settings -----------------------------------------------------------------

    def live_values(self):
        """The live settings in force: time_scale and LIVE_PARAMETERS."""
        with self.lock:
            values = {name: getattr(self.params, name) for name in LIVE_PARAMETERS}
            values['time_scale'] = self.time_scale
            return values

    def set_live(self, name, value):
        """Change one live setting, validated like its start-up value; BatteryError (the old value kept)."""
        if name == 'time_scale':
            try:
                check_setting(setting('time_scale'), value)
            except SettingError as error:
                raise BatteryError('%s; keeping %g' % (error, self.time_scale)) from None
            with self.lock:
                self._step_to(self._clock())   # the time so far at the old setting
                self.time_scale = float(value)
                if not self.sim_time:
                    self._time_base.time_scale = self.time_scale
            return
        if name not in LIVE_PARAMETERS:
            raise BatteryError('%s is not a live setting; live: time_scale, %s' % (name, ', '.join(LIVE_PARAMETERS)))
        if not is_number(value):
            raise BatteryError(refusal(name, value, 'must be a number; keeping %g' % getattr(self.params, name)))
        with self.lock:
            try:
                params = replace(self.params, **{name: float(value)})
            except ParameterError as error:
                raise BatteryError('%s; keeping %g' % (error, getattr(self.params, name))) from None
            self._step_to(self._clock())   # the time so far at the old setting
            self.model.params = params


def new_battery(params, settings, charging, mode_name, log, ros_clock=None):
    """The one way every front end builds a battery (a single node's, a fleet robot's): ``params`` (the
    config), ``settings`` (core/node_settings.py BATTERY_SETTINGS' initial_percentage, time_scale and
    max_time_jump; the last two may be missing), ``charging`` (the start-up mode), ``mode_name`` (what the
    front end calls the mode), ``log`` (a BatteryLog); ``ros_clock()``: the front end's ROS time under
    use_sim_time, None on wall time (monotonic, scaled by time_scale)."""
    sim_time = ros_clock is not None
    return Battery(params, settings['initial_percentage'], charging, clock=ros_clock if sim_time else time.monotonic,
                   sim_time=sim_time, time_scale=settings.get('time_scale', setting('time_scale').default),
                   mode_name=mode_name, log=log, max_time_jump=settings.get('max_time_jump', DEFAULT_MAX_TIME_JUMP_S))


class _SilentLog:
    def _nothing(self, *args):
        pass

    info = warn = error = progress = _nothing

    def info_throttle(self, period_s, *args):
        pass

    warn_throttle = error_throttle = info_throttle
