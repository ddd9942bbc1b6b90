"""The battery_simulator action server node (BatterySimServer in sim.launch).

It owns the one battery model. A worker thread steps it at ``~update_rate``,
following the mode parameter ``MyRobot/BatteryStatus`` at every step, takes
and ends the goals of the action ``battery_simulator`` (Full when charging,
Empty when discharging, preempted, or aborted when the mode turns against
them), and publishes the model's state for battery_state_pub. The charger
contact, the motion and payload loads, the test controls and the faults all
act on the model through the same lock.

:ROS Parameters:
  - ``~config`` (str): YAML battery config: a ``preset`` plus overrides
    (default: the package's config/battery.yaml)
  - ``~time_scale`` (float > 0): simulated seconds per wall second (default 22;
    ignored under /use_sim_time, where ROS time drives the model); live-tunable
  - ``~update_rate`` (float, Hz, 0 < r <= 1000): model updates per second (default 10)
  - ``~initial_percentage`` (float, 0..100): charge at start (default 100)
  - ``~charging`` (bool): written to MyRobot/BatteryStatus at start (default false)
  - ``~state_file`` (str): optional JSON file the state is saved to and resumed from
  - ``~saved_state`` (dict): written by the node; a respawned node resumes from it
  - ``MyRobot/BatteryStatus`` (1/true charge, 0/false discharge, unset hold)
  - dynamic_reconfigure (cfg/BatterySim.cfg): ``time_scale``, ``load_current_a``,
    ``load_power_w``, ``charge_current_a``, ``ambient_temperature_c``,
    ``drive_power_w_per_mps``, ``turn_power_w_per_radps``

:Subscribes:
  - ``cmd_vel`` (geometry_msgs/Twist): motion load while discharging
  - ``charger_contact`` (std_msgs/Bool): a change connects (true) or disconnects the charger
  - ``battery_simulator/status_sent`` (std_msgs/UInt64): battery_state_pub has sent a service's change

:Publishes:
  - ``battery_simulator/state`` (battery_simulator/BatterySimState, latched): after every update

:Services:
  - ``battery_simulator/set_load`` (battery_simulator/SetLoad): named payload loads
  - ``battery_simulator/set_charging`` (std_srvs/SetBool): as a charger contact change
  - ``battery_simulator/set_state`` (battery_simulator/SetState): percentage, temperature, health
  - ``battery_simulator/reset`` (std_srvs/Trigger): back to the start-up state, mode kept
  - ``battery_simulator/inject_fault`` (battery_simulator/InjectFault): see FAULTS
  - ``battery_simulator/predict`` (battery_simulator/Predict): what a plan of loads (and a charge after
    it) would do, from a copy of the model (core/prediction.py), computed in the process's prediction
    workers (prediction_service.py); changes nothing, so it replies once computed
  Each other service (and dynamic_reconfigure) replies once battery_state_pub has sent the
  state it changed on battery_status (publish_now, acknowledged on status_sent; without
  a battery_state_pub, once it is published), so the next battery_status shows the change.
"""
import math
import pickle
import random
import threading
import time
from contextlib import contextmanager
from dataclasses import replace

import actionlib
import rospy
from dynamic_reconfigure.server import Server as ReconfigureServer
from geometry_msgs.msg import Twist
from sensor_msgs.msg import BatteryState
from std_msgs.msg import Bool, UInt64
from std_srvs.srv import SetBool, SetBoolResponse, Trigger, TriggerResponse

from battery_simulator.battery import prediction_service
from battery_simulator.battery.battery_state import SimState
from battery_simulator.battery.robot_log import RobotLog
from battery_simulator.battery.saved_state import StateStore
from battery_simulator.battery.workers import StatusTimer, UpdateLoop
from battery_simulator.cfg import BatterySimConfig
from battery_simulator.core.battery_model import MIN_STATE_OF_HEALTH, BatteryModel, CutOff, Mode, Status
from battery_simulator.core.parameters import (MAX_SPEED_MPS, MAX_TURN_RADPS, ParameterError, default_config_path,
                                               load_power_error, load_yaml)
from battery_simulator.core.time_base import TimeBase
from battery_simulator.msg import (BatterySimState, battery_simAction, battery_simFeedback,
                                   battery_simResult)
from battery_simulator.ros import topics
from battery_simulator.ros.cached_param import CachedParam
from battery_simulator.ros.startup import (StartupError, checked_param, init_node, is_number, signals_held,
                                           wait_for_rosout)
from battery_simulator.srv import (InjectFault, InjectFaultResponse, SetLoad, SetLoadResponse, SetState,
                                   SetStateResponse)

FEEDBACK_PERIOD_S = 1.0   # feedback at least this often, even when the model is paused
INVALID_LOG_PERIOD_S = 10.0
OVERHEAT_MARGIN_K = 2.0   # the overheat fault holds the pack this far above its overheat limit
LOG_PERIOD_S = 1.0        # lines an input can repeat at any rate (contact flapping) at most this often
SERVICE_PUBLISH_WAIT_S = 1.0   # a service's reply waits this long (wall) for its change to be published
FAULTS = {
    'charger_fault': 'charger connected but no current flows',
    'overheat': 'the pack heats past its overheat limit',
    'sensor_dropout': 'battery_status stops; the model runs on',
    'measurement_noise': 'Gaussian noise on the reported voltage and current',
}
#: the dynamic_reconfigure keys that are battery parameters (time_scale is the node's)
LIVE_PARAMETERS = ('load_current_a', 'load_power_w', 'charge_current_a', 'ambient_temperature_c',
                   'drive_power_w_per_mps', 'turn_power_w_per_radps')
#: the model's named loads: cmd_vel's motion, set_load's payloads
MOTION_LOAD = 'motion'
PAYLOAD_LOAD = 'payload'
_INVALID = object()


def parse_mode(value):
    """The Mode a MyRobot/BatteryStatus value asks for, or _INVALID. Unset holds (IDLE)."""
    if value is None:
        return Mode.IDLE
    if isinstance(value, bool):
        return Mode.CHARGE if value else Mode.DISCHARGE
    if isinstance(value, (int, float)) and value in (0, 1):
        return Mode.CHARGE if value == 1 else Mode.DISCHARGE
    return _INVALID


def read_settings():
    """All start-up parameters, checked; raises StartupError."""
    config = checked_param('~config', str(default_config_path()),
                           lambda v: isinstance(v, str) and v != '', 'a path to a YAML file')
    try:
        params = load_yaml(config)
    except ParameterError as error:
        raise StartupError('parameter %s = %r is invalid: %s' % (rospy.resolve_name('~config'), config, error)) \
            from None
    return dict(
        params=params,
        params_path=config,
        time_scale=checked_param('~time_scale', 22.0, lambda v: is_number(v) and v > 0, 'a number > 0'),
        update_rate=checked_param('~update_rate', 10.0, lambda v: is_number(v) and 0 < v <= 1000,
                                  'a number in (0, 1000] Hz'),
        initial_percentage=checked_param('~initial_percentage', 100.0,
                                         lambda v: is_number(v) and 0 <= v <= 100, 'a number in [0, 100]'),
        charging=checked_param('~charging', False, lambda v: v in (True, False, 0, 1),
                               'true or false (or 1 / 0)'),
        state_file=checked_param('~state_file', '', lambda v: isinstance(v, str), 'a file path (or empty)'),
    )


class ActiveGoal:
    """The goal being pursued: the mode it asked for and where it ends."""

    def __init__(self, charge):
        self.mode = Mode.CHARGE if charge else Mode.DISCHARGE
        self.target = Status.FULL if charge else Status.EMPTY
        self.done_text = 'Full' if charge else 'Empty'


class BatterySimServer:
    """The action server, the worker thread that steps the model, and the controls.

    Lock order: ``self._lock`` (a Condition) guards the model, the mode
    bookkeeping, the loads and the faults; it is taken last and held briefly (a
    service waiting for its change to go out releases it in Condition.wait_for).
    Goals are taken, fed and ended only by the worker thread, never while it
    holds ``self._lock``, so actionlib's own locks are always taken first.
    """

    def __init__(self, namespace, node_name, params, time_scale, initial_percentage, charging, store, loop,
                 status_timer, log=None):
        """One battery whose names live under ``namespace`` ('/', '/robot3/'); ``node_name`` is where its
        dynamic_reconfigure lives (its node, or '/robot3/BatterySimServer' in a fleet host); ``store``
        keeps its saved state; ``loop`` (UpdateLoop) steps it; ``status_timer`` publishes its goal status."""
        self.params = params
        self._ns = namespace
        self._node_name = node_name
        self._log = log or RobotLog()
        self._initial_soc = initial_percentage / 100.0
        self._sim_time = bool(rospy.get_param('/use_sim_time', False))
        self._time_scale = time_scale      # as configured (the time base ignores it under sim time)
        if self._sim_time:
            self._clock, self._time_base = rospy.get_time, TimeBase(1.0, zero_is_unset=True)
        else:
            self._clock, self._time_base = time.monotonic, TimeBase(time_scale)
        self._lock = threading.Condition()
        self._loop = loop
        self._status_timer = status_timer
        self._updates = 0                  # model updates taken for publishing (worker)
        self._urgent_update = 0            # the update a service asked for: battery_status shows it at once
        self._published_update = 0         # the last update published on battery_simulator/state
        self._sent_update = 0              # the last publish_now update battery_state_pub has sent on
        self._stopping = threading.Event()
        self._mode_generation = 0          # bumped whenever the mode is set other than by the parameter
        self._mode_source = 'parameter'    # who set the mode last (for abort texts)
        self._mode_param = CachedParam(namespace + topics.MODE_PARAM)
        self._contact = False              # the charger contact as last reported
        self._motion = (None, 0.0, 0.0)    # (clock time, |v| m/s, |w| rad/s) of the last cmd_vel
        self._motion_since = None          # clock time the motion energy is accounted up to
        self._motion_energy_j = 0.0        # motion energy since the model's last step, J
        self._payloads = {}                # name -> W
        self._faults = set()
        self._noise = random.Random()
        self._goal = None                  # ActiveGoal, worker thread only
        self._logged = (None, 0.0)         # (whole percent, wall time) of the last progress line
        self._invalid_logged = (None, 0.0)  # (repr of the bad mode value, wall time) last logged
        self._store = store
        self._state_listeners = []         # in-process battery_state_pub logic (a fleet host): called per update
        self._sent_sub = None              # battery_state_pub's acknowledgements, when it is another process

        self.model = BatteryModel(params, state_of_charge=self._initial_soc,
                                  mode=Mode.CHARGE if charging else Mode.DISCHARGE)
        resumed_from = self._resume()
        if resumed_from is None:
            self._mode_param.set(1 if charging else 0)
        self._follow(self._read_mode_param())
        self.model.step(0.0)
        self._resumed_from = resumed_from

        self._latest_state = None
        # a subscriber gets the latest state when it connects (as a latched topic, without building
        # and serializing a message at every update while nobody listens)
        self._state_pub = rospy.Publisher(namespace + topics.STATE_TOPIC, BatterySimState, queue_size=1,
                                          subscriber_listener=_LatestStateOnConnect(self))
        self._server = actionlib.SimpleActionServer(namespace + topics.ACTION, battery_simAction, auto_start=False)
        self._server.register_goal_callback(self._wake_up)
        self._server.register_preempt_callback(self._wake_up)
        loop.add(self)

    def add_state_listener(self, listener):
        """Call ``listener(BatterySimState)`` after every update, in the worker thread (an in-process publisher)."""
        self._state_listeners.append(listener)

    def _resume(self):
        """Resume a saved state (after a respawn, or from ~state_file); where from, or None."""
        saved, where = self._store.load()
        if saved is None:
            return None
        try:
            self.model.restore_state(saved)
        except ValueError as error:
            self._log.warn('not resuming from %s: %s; starting at %.1f %%', where, error, 100 * self._initial_soc)
            return None
        return where

    def start(self):
        ns = self._ns
        self._subscribers = [rospy.Subscriber(ns + topics.CMD_VEL, Twist, self._on_cmd_vel, queue_size=1),
                             rospy.Subscriber(ns + topics.CHARGER_CONTACT, Bool, self._on_contact, queue_size=10)]
        if not self._state_listeners:   # battery_state_pub is another process: it acknowledges on a topic
            self._sent_sub = rospy.Subscriber(ns + topics.STATUS_SENT, UInt64,
                                              lambda msg: self.on_status_sent(msg.data), queue_size=10)
        self._services = [
            rospy.Service(ns + topics.SET_LOAD, SetLoad, self._set_load),
            rospy.Service(ns + topics.SET_CHARGING, SetBool, self._set_charging),
            rospy.Service(ns + topics.SET_STATE, SetState, self._set_state),
            rospy.Service(ns + topics.RESET, Trigger, self._reset),
            rospy.Service(ns + topics.INJECT_FAULT, InjectFault, self._inject_fault),
            prediction_service.advertise(ns + topics.PREDICT, self._predict),
        ]
        self._publish_state(self.model.snapshot())
        self._server.start()
        self._status_timer.add(self._server)
        self._reconfigure = self._start_reconfigure()

    def report_ready(self, resumed_only=False):
        """The start-up lines (after /rosout listens): resumed, and ready unless ``resumed_only``."""
        snapshot = self.model.snapshot()
        if self._resumed_from:
            self._log.info('battery_simulator resumed from %s: %.1f %%, %.2f cycles, state of health %.1f %%',
                           self._resumed_from, snapshot.percentage, snapshot.cycle_count,
                           100.0 * snapshot.state_of_health)
        if not resumed_only:
            self._log.info('battery_simulator ready: %s, %.1f %%, %s, %s', self.params.name, snapshot.percentage,
                           snapshot.status.value,
                           'ROS time' if self._sim_time else 'time x%g' % self._time_base.time_scale)

    def _start_reconfigure(self):
        values = {name: getattr(self.params, name) for name in LIVE_PARAMETERS}
        values['time_scale'] = self._time_scale
        return _LiveSettings(values, self._reconfigure_callback, namespace=self._node_name + '/')

    def _wake_up(self):
        """Update and publish now (callers may hold self._lock: the loop's lock is taken after it)."""
        self._loop.wake(self)

    def _advance_to_now(self):
        """Step the model up to this moment (self._lock held) before a change, so that the change
        does not act on the time before it (one update period: 100 s of battery at time x1000, 10 Hz)."""
        self._step_to(self._clock())

    def _step_to(self, now):
        """Step the model to ``now`` (self._lock held) with the motion load it had meanwhile: the energy of
        every cmd_vel over the time it held, so an update period of any length (24 s of ROS time at
        speed 240) drains what the robot's motion took. Returns that average motion power, W."""
        self._account_motion(now)
        dt_s = self._time_base.elapsed(now)
        motion_w = self._motion_energy_j / dt_s if dt_s > 0.0 else self._motion_power_w(now)
        self._motion_energy_j = 0.0
        self.model.set_extra_load(MOTION_LOAD, power_w=motion_w)
        self.model.step(dt_s)
        return motion_w

    def _account_motion(self, now):
        """Add the energy of the command held since the last accounting (self._lock held): a cmd_vel
        counts from its arrival until the next one or until it times out, on the model's clock."""
        stamp, speed, turn = self._motion
        since, self._motion_since = self._motion_since, now
        if stamp is None or since is None or now <= since:
            return   # nothing commanded yet, or the clock jumped back
        held_s = min(now, stamp + self.params.cmd_vel_timeout_s) - max(since, stamp)   # on the clock
        if held_s > 0.0:   # in simulated seconds, as the model steps
            self._motion_energy_j += held_s * self._time_base.time_scale * self.params.motion_power_w(speed, turn)

    @contextmanager
    def _service_change(self):
        """Hold self._lock around a service's change. The model is first stepped to now; after the
        change the next update carries it and battery_state_pub sends it on battery_status at once.
        Waits (bounded) until it has, so the caller's reply comes after that battery_status (without
        a battery_state_pub to acknowledge, until the state is published). A change that raises
        (refused) is not waited for."""
        with self._lock:
            self._advance_to_now()
            yield
            wanted = self._updates + 1
            self._urgent_update = wanted
            acknowledged = bool(self._state_listeners) or (
                self._sent_sub is not None and self._sent_sub.get_num_connections() > 0)
            self._wake_up()
            self._lock.wait_for(lambda: self._stopping.is_set() or (
                self._published_update >= wanted and (not acknowledged or self._sent_update >= wanted)),
                SERVICE_PUBLISH_WAIT_S)

    def on_status_sent(self, update):
        """battery_state_pub has sent publish_now ``update`` on battery_status (a waiting service may reply)."""
        with self._lock:
            self._sent_update = max(self._sent_update, update)
            self._lock.notify_all()

    # -- the worker thread ----------------------------------------------------

    def run_once(self):
        """One turn of the worker (UpdateLoop): take goals, update; False once rospy shuts down."""
        try:
            self._take_goals()
            self._update()
        except rospy.ROSException as error:   # a topic closed under us: only at shutdown
            if rospy.is_shutdown():
                return False
            self._log.error_throttle(10.0, 'battery update failed: %s', error)
        return True

    def finish(self):
        """At shutdown (the worker): preempt the active goal and save the state."""
        self._stopping.set()
        with self._lock:
            self._lock.notify_all()
            state = self.model.export_state()
        try:
            self._preempt('server shutting down')
        except rospy.ROSException:
            pass   # too late: rospy has closed the action's topics
        self._store.save_now(state)

    def _update(self):
        """One model update: follow the mode, apply loads and faults, step, publish, check the goal."""
        with self._lock:
            generation = self._mode_generation
        raw_mode = self._read_mode_param()
        with self._lock:   # the clock is read under the lock: a service may step the model to its own now
            now = self._clock()
            restarts = self._time_base.restarts
            if generation == self._mode_generation:  # else the mode was set meanwhile, and stands
                self._follow(raw_mode)
            if 'overheat' in self._faults:
                self.model.temperature_c = max(self.model.temperature_c,
                                               self.params.overheat_temperature_c + OVERHEAT_MARGIN_K)
            motion_w = self._step_to(now)
            snapshot = self.model.snapshot()
            state = self.model.export_state()
            load_w = motion_w + sum(self._payloads.values())
            self._updates += 1
            update, urgent = self._updates, self._updates == self._urgent_update
        if self._time_base.restarts != restarts:
            self._log.warn('ROS time moved backwards (to %.3f s): time base restarted, nothing drained', now)
        self._publish_state(snapshot, load_w, publish_now=urgent, update=update)
        with self._lock:
            self._published_update = update
            self._lock.notify_all()
        self._store.maybe_save(state)
        self._log_progress(snapshot)
        self._check_goal(snapshot)

    def _motion_power_w(self, now):
        """The motion power of the command in force at ``now``, W."""
        stamp, speed, turn = self._motion
        if stamp is None or not 0.0 <= now - stamp <= self.params.cmd_vel_timeout_s:
            return 0.0
        return self.params.motion_power_w(speed, turn)

    def _read_mode_param(self):
        try:
            return self._mode_param.get()
        except (ConnectionError, OSError) as error:  # master gone: keep the mode
            self._log.warn_throttle(10.0, 'cannot read %s: %s', self._mode_param.name, error)
            return _INVALID

    def _follow(self, raw_mode):
        mode = parse_mode(raw_mode)
        if mode is _INVALID:
            if raw_mode is not _INVALID:
                self._log_invalid_mode(raw_mode)
            return
        self._invalid_logged = (None, 0.0)
        if mode is not self.model.mode:
            self._mode_source = 'parameter'
            self.model.set_mode(mode)

    def _set_mode(self, mode, source):
        """Set the mode and the parameter together (a goal, the charger contact, set_charging)."""
        with self._lock:
            self._advance_to_now()
            self._mode_generation += 1
            self._mode_param.set(1 if mode is Mode.CHARGE else 0)
            self._mode_source = source
            self.model.set_mode(mode)
            self._wake_up()

    def _log_invalid_mode(self, raw_mode):
        """An error at once for each new bad value, then every INVALID_LOG_PERIOD_S while it stays."""
        value, logged_at = self._invalid_logged
        now = time.monotonic()
        if value == repr(raw_mode) and now - logged_at < INVALID_LOG_PERIOD_S:
            return
        self._invalid_logged = (repr(raw_mode), now)
        self._log.error('%s = %r is invalid: must be 1/true (charge), 0/false (discharge) or unset '
                     '(hold); keeping %s', self._mode_param.name, raw_mode, self.model.mode.value)

    def _publish_state(self, snapshot, load_w=0.0, publish_now=False, update=0):
        """Hand this update's state to battery_state_pub: on the state topic while someone subscribes,
        and to the in-process listeners (its message is built only if one of them needs it)."""
        with self._lock:
            faults = set(self._faults)
        state = SimState(snapshot, self.params, rospy.Time.now(), load_w, faults, publish_now, update,
                         self._add_noise if 'measurement_noise' in faults else None)
        self._latest_state = state
        if self._state_pub.get_num_connections() > 0:
            self._state_pub.publish(state.message())
        for listener in self._state_listeners:
            listener(state)

    def _add_noise(self, battery):
        """The measurement_noise fault: Gaussian noise on the reported voltage and current."""
        battery.voltage = noisy_voltage(battery.voltage, self._noise.gauss(0.0, self.params.voltage_noise_v))
        battery.current = noisy_current(battery.current, self._noise.gauss(0.0, self.params.current_noise_a),
                                        battery.power_supply_status)
        battery.cell_voltage = [battery.voltage / len(battery.cell_voltage)] * len(battery.cell_voltage)

    def _log_progress(self, snapshot):
        whole = int(snapshot.percentage)
        logged_percent, logged_at = self._logged
        now = time.monotonic()
        if whole != logged_percent and now - logged_at >= 1.0:
            self._logged = (whole, now)
            self._log.progress('%s... %d %% (%.2f V, %+.2f A)', snapshot.status.value.capitalize(),
                               whole, snapshot.voltage_v, snapshot.current_a)

    # -- goals (worker thread) ---------------------------------------------------

    def _take_goals(self):
        """Accept a new goal (preempting the active one) or act on a cancel."""
        if self._server.is_new_goal_available():
            self._preempt('a new goal')
            goal = self._server.accept_new_goal()
            if goal is None:
                return
            self._goal = ActiveGoal(goal.charge_state)
            self._set_mode(self._goal.mode, 'goal')
            snapshot = self._snapshot_now()
            self._log.info('goal: %s from %.1f %%', self._goal.mode.value, snapshot.percentage)
            if self._server.is_preempt_requested():   # cancelled before it was accepted
                self._preempt('cancel')
            else:
                self._check_goal(snapshot)
        elif self._goal is not None and self._server.is_preempt_requested():
            self._preempt('cancel')

    def _snapshot_now(self):
        with self._lock:
            self.model.step(0.0)
            return self.model.snapshot()

    def _check_goal(self, snapshot):
        """Feedback for the active goal, and its end if it has reached one."""
        goal = self._goal
        if goal is None:
            return
        self._server.publish_feedback(battery_simFeedback(battery_percentage=snapshot.percentage))
        if snapshot.status is goal.target and snapshot.cut_off in (None, CutOff.UNDER_VOLTAGE):
            self._finish(self._server.set_succeeded, goal.done_text, self._log.info)
        elif snapshot.mode is not goal.mode:
            self._finish(self._server.set_aborted, 'Aborted at %.1f %%: %s was changed to %s (%s) while %s' % (
                snapshot.percentage, self._mode_param.name, snapshot.mode.value,
                self._mode_source, goal.mode.value), self._log.warn)
        elif snapshot.status is Status.EMPTY:
            self._finish(self._server.set_aborted, 'Aborted at %.1f %%: the pack protection cut the load off (%s)'
                         % (snapshot.percentage, snapshot.cut_off.value), self._log.warn)

    def _preempt(self, reason):
        """Preempt the active goal, if any, saying why and at what level."""
        if self._goal is not None:
            snapshot = self._snapshot_now()
            self._finish(self._server.set_preempted, 'Preempted at %.1f %% (%s, %s)' % (
                snapshot.percentage, reason, snapshot.status.value), self._log.info)

    def _finish(self, set_state, text, log):
        self._goal = None
        set_state(battery_simResult(battery_status=text), text)
        log('goal ended: %s', text)

    # -- inputs (subscriber and service threads) ---------------------------------

    def _on_cmd_vel(self, twist):
        speed, turn = abs(twist.linear.x), abs(twist.angular.z)
        if not (speed <= MAX_SPEED_MPS and turn <= MAX_TURN_RADPS):   # also NaN
            self._log.error_throttle(10.0, 'ignoring a cmd_vel beyond what a robot can do (|linear.x| %r m/s, '
                                  '|angular.z| %r rad/s; at most %g and %g)', speed, turn, MAX_SPEED_MPS,
                                  MAX_TURN_RADPS)
            return
        with self._lock:
            now = self._clock()
            self._account_motion(now)   # the previous command's energy up to now
            self._motion = (now, speed, turn)

    def _on_contact(self, msg):
        self._change_contact(bool(msg.data), 'charger contact')

    def _set_charging(self, request):
        with self._service_change():
            self._change_contact(bool(request.data), 'set_charging')
        return SetBoolResponse(success=True, message='charger %s' % ('connected' if request.data else 'disconnected'))

    def _change_contact(self, connected, source):
        """Only a change acts: connected -> charge, disconnected -> discharge."""
        with self._lock:
            changed, self._contact = connected != self._contact, connected
        if changed:
            self._log.info_throttle(LOG_PERIOD_S, '%s: charger %s', source, 'connected' if connected else 'disconnected')
            self._set_mode(Mode.CHARGE if connected else Mode.DISCHARGE, source)

    def _set_load(self, request):
        name, power_w = request.name.strip(), request.power_w
        if not name:
            return SetLoadResponse(success=False, message='name must not be empty')
        error = load_power_error(self.params, 'power_w', power_w, power_w, 'it')
        if error:
            return SetLoadResponse(success=False, message=error)
        with self._service_change():
            total_w = sum(p for n, p in self._payloads.items() if n != name) + power_w
            error = load_power_error(self.params, 'power_w', power_w, total_w, 'the payload loads')
            if error:
                return SetLoadResponse(success=False, message=error)
            if power_w > 0.0:
                self._payloads[name] = power_w
            else:
                self._payloads.pop(name, None)
            self.model.set_extra_load(PAYLOAD_LOAD, power_w=sum(self._payloads.values()))
            total = sum(self._payloads.values())
        return SetLoadResponse(success=True, message='%s: %g W; payload loads now %g W' % (name, power_w, total))

    def _set_state(self, request):
        def given(value):
            return None if math.isnan(value) else value
        percentage = given(request.percentage)
        try:
            with self._service_change():
                self.model.set_state(None if percentage is None else percentage / 100.0,
                                     given(request.temperature_c), given(request.state_of_health))
        except ValueError as error:
            return SetStateResponse(success=False, message=str(error).replace('state_of_charge', 'percentage/100'))
        return SetStateResponse(success=True, message='state set')

    def _reset(self, request):
        with self._service_change():
            self.model.set_state(self._initial_soc, self.model.initial_temperature_c,
                                 max(MIN_STATE_OF_HEALTH,
                                     1.0 - self.params.capacity_fade_per_cycle * self.params.initial_cycle_count))
            self.model.discharged_ah = 0.0
            cleared, self._faults = sorted(self._faults), set()   # the start-up state has no faults
            self.model.set_charger_fault(False)
        if cleared:
            self._log.warn('reset: faults cleared: %s', ', '.join(cleared))
        return TriggerResponse(success=True, message='reset to %.1f %%, mode kept%s' % (
            100.0 * self._initial_soc, '; faults cleared: ' + ', '.join(cleared) if cleared else ''))

    def _inject_fault(self, request):
        if request.fault not in FAULTS:
            return InjectFaultResponse(success=False, message='unknown fault %r; known faults: %s' % (
                request.fault, '; '.join('%s (%s)' % item for item in sorted(FAULTS.items()))))
        with self._service_change():
            if request.active:
                self._faults.add(request.fault)
            else:
                self._faults.discard(request.fault)
            if request.fault == 'charger_fault':
                self.model.set_charger_fault(request.active)
        self._log.warn('fault %s %s', request.fault, 'injected' if request.active else 'cleared')
        return InjectFaultResponse(success=True, message='%s %s' % (request.fault, 'active' if request.active
                                                                      else 'cleared'))

    def _predict(self, request):
        """What the request's plan would do, from a copy of the model taken under the lock (computed in the
        process's prediction workers): the copy is brought to now at its present loads, and the plan's
        motion takes the place of cmd_vel's."""
        with self._lock:
            model = pickle.dumps(self.model, pickle.HIGHEST_PROTOCOL)
            behind_s = self._time_base.pending(self._clock())
        return prediction_service.answer(self._ns, request, model, behind_s, dropped_loads=(MOTION_LOAD,))

    def _reconfigure_callback(self, config, level):
        """Apply live changes, validated like the start-up values: a refused value is logged and the old one kept.

        The .cfg gives no bounds, so dynamic_reconfigure clamps nothing before this check.
        """
        time_scale = config['time_scale']
        with self._service_change():   # the time so far at the old settings (and time_scale)
            if not (is_number(time_scale) and time_scale > 0):
                self._log.error('dynamic_reconfigure: time_scale = %r is invalid: must be a number > 0; keeping %g',
                             time_scale, self._time_scale)
            else:
                self._time_scale = time_scale
                if not self._sim_time:
                    self._time_base.time_scale = time_scale
            params = self.params
            for name in LIVE_PARAMETERS:
                if config[name] == getattr(params, name):
                    continue
                try:
                    params = replace(params, **{name: float(config[name])})
                except ParameterError as error:
                    self._log.error('dynamic_reconfigure: %s; keeping %g', error, getattr(params, name))
            self.params = self.model.params = params
        config['time_scale'] = self._time_scale
        for name in LIVE_PARAMETERS:
            config[name] = getattr(params, name)
        return config


class _LiveSettings(ReconfigureServer):
    """dynamic_reconfigure's server, starting from the values in force rather than from the parameter
    server (which would impose the .cfg defaults, and cost 14 master calls a robot in a fleet host)."""

    def __init__(self, values, callback, namespace):
        self._values_in_force = values
        super().__init__(BatterySimConfig, callback, namespace=namespace)

    def _copy_from_parameter_server(self):
        self.config.update(self._values_in_force)


class _LatestStateOnConnect(rospy.SubscribeListener):
    def __init__(self, server):
        super().__init__()
        self._server = server

    def peer_subscribe(self, topic_name, topic_publish, peer_publish):
        state = self._server._latest_state
        if state is not None:
            peer_publish(state.message())


def noisy_voltage(voltage_v, noise_v):
    """A noisy voltage reading: never <= 0 or beyond twice the true value (sigma is bounded by the config)."""
    return min(max(voltage_v + noise_v, 0.5 * voltage_v), 2.0 * voltage_v)


def noisy_current(current_a, noise_a, power_supply_status):
    """A noisy current reading whose sign never contradicts the status (negative discharging, positive charging)."""
    noisy = current_a + noise_a
    if power_supply_status == BatteryState.POWER_SUPPLY_STATUS_DISCHARGING:
        return min(noisy, 0.0)
    if power_supply_status == BatteryState.POWER_SUPPLY_STATUS_CHARGING:
        return max(noisy, 0.0)
    return noisy


def main():
    with signals_held():
        settings = init_node('BatterySimServer', read_settings)
        settings.pop('params_path')
        loop = UpdateLoop(settings.pop('update_rate'))
        store = StateStore(rospy.resolve_name('~saved_state'), settings.pop('state_file'))
        server = BatterySimServer(rospy.get_namespace(), rospy.get_name(), store=store, loop=loop,
                                  status_timer=StatusTimer(), **settings)
        rospy.on_shutdown(loop.stop)   # client hooks run before rospy closes the topics
        loop.start()     # first: dynamic_reconfigure's first callback waits for an update
        server.start()
        wait_for_rosout()
        server.report_ready()
    rospy.spin()
    loop.stop()
