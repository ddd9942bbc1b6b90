"""The battery_simulator action server node (BatterySimServer in sim.launch).

It owns the one battery model. A worker thread steps it at ``~update_rate``,
following the mode parameter ``MyRobot/BatteryStatus`` at every step, and
publishes the model's state for battery_state_pub. Goals of the action
``battery_simulator`` set that parameter and end Full (charging) or Empty
(discharging), preempted, or aborted when the parameter turns against them.

:ROS Parameters:
  - ``~config`` (str): YAML battery config: a ``preset`` plus overrides
    (default: the package's config/battery.yaml)
  - ``~time_scale`` (float > 0): simulated seconds per wall second (default 22;
    ignored under /use_sim_time, where ROS time drives the model)
  - ``~update_rate`` (float, Hz, 0 < r <= 1000): model updates per second (default 10)
  - ``~initial_percentage`` (float, 0..100): charge at start (default 100)
  - ``~charging`` (bool): written to MyRobot/BatteryStatus at start (default false)
  - ``MyRobot/BatteryStatus`` (1/true charge, 0/false discharge, unset hold)

:Publishes:
  - ``battery_simulator/battery_state`` (sensor_msgs/BatteryState, latched):
    the model after every update, for battery_state_pub
"""
import threading
import time

import actionlib
import rospy
from sensor_msgs.msg import BatteryState

from battery_simulator.battery_model import BatteryModel, Mode, Status
from battery_simulator.battery_state import to_battery_state
from battery_simulator.msg import battery_simAction, battery_simFeedback, battery_simResult
from battery_simulator.parameters import ParameterError, default_config_path, load_yaml
from battery_simulator.ros_parameters import (StartupError, checked_param, exit_on_startup_error,
                                              is_number)

MODE_PARAM = 'MyRobot/BatteryStatus'
STATE_TOPIC = 'battery_simulator/battery_state'
FEEDBACK_PERIOD_S = 1.0   # feedback at least this often, even when the model is paused
INVALID_LOG_PERIOD_S = 10.0
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
    """All start-up parameters, checked; raises StartupError or ParameterError."""
    config = checked_param('~config', str(default_config_path()),
                           lambda v: isinstance(v, str) and v != '', 'a path to a YAML file')
    try:
        params = load_yaml(config)
    except ParameterError as error:
        raise StartupError('parameter %s = %r is invalid: %s' % (rospy.resolve_name('~config'), config, error)) \
            from None
    settings = dict(
        params=params,
        time_scale=checked_param('~time_scale', 22.0, lambda v: is_number(v) and v > 0, 'a number > 0'),
        update_rate=checked_param('~update_rate', 10.0, lambda v: is_number(v) and 0 < v <= 1000,
                                  'a number in (0, 1000] Hz'),
        initial_percentage=checked_param('~initial_percentage', 100.0,
                                         lambda v: is_number(v) and 0 <= v <= 100, 'a number in [0, 100]'),
        charging=checked_param('~charging', False, lambda v: v in (True, False, 0, 1),
                               'true or false (or 1 / 0)'),
    )
    return settings


class BatterySimServer:
    """The action server and the worker thread that steps the model.

    Lock order: ``self._updated`` (a Condition on one lock) guards the model,
    the latest snapshot and the mode bookkeeping. It is the only lock taken
    here; actionlib calls (set_succeeded, publish_feedback, ...) are never
    made while holding it.
    """

    def __init__(self, params, time_scale, update_rate, initial_percentage, charging):
        self.params = params
        self._period_s = 1.0 / update_rate
        if rospy.get_param('/use_sim_time', False):
            self._clock, self._time_scale = rospy.get_time, 1.0
        else:
            self._clock, self._time_scale = time.monotonic, time_scale
        initial_mode = Mode.CHARGE if charging else Mode.DISCHARGE
        self.model = BatteryModel(params, state_of_charge=initial_percentage / 100.0, mode=initial_mode)
        self._updated = threading.Condition()
        self._update_count = 0
        self._mode_generation = 0   # bumped whenever a goal writes the mode parameter
        self._stopping = threading.Event()
        self._logged = (None, 0.0)  # (whole percent, wall time) of the last progress line
        self._invalid_logged = (None, 0.0)  # (repr of the bad mode value, wall time) last logged
        rospy.set_param(MODE_PARAM, 1 if charging else 0)
        self._state_pub = rospy.Publisher(STATE_TOPIC, BatteryState, queue_size=1, latch=True)
        self._server = actionlib.SimpleActionServer(
            'battery_simulator', battery_simAction, execute_cb=self._execute, auto_start=False)
        self._worker = threading.Thread(target=self._run, name='battery_model')

    def start(self):
        rospy.on_shutdown(self.stop)
        snapshot = self.model.snapshot()
        self._publish_state(snapshot)
        self._worker.start()
        self._server.start()
        rospy.loginfo('battery_simulator ready: %s, %.1f %%, %s, time x%g',
                      self.params.name, snapshot.percentage, snapshot.status.value, self._time_scale)

    def stop(self):
        """Stop the worker; an active goal is preempted by its execute loop."""
        self._stopping.set()
        with self._updated:
            self._updated.notify_all()
        if self._worker.is_alive() and threading.current_thread() is not self._worker:
            self._worker.join(timeout=2.0)

    # -- the worker thread ----------------------------------------------------

    def _run(self):
        last = self._clock()
        while not rospy.is_shutdown() and not self._stopping.wait(self._period_s):
            with self._updated:
                generation = self._mode_generation
            raw_mode = self._read_mode_param()
            now = self._clock()
            dt_s, last = max(0.0, now - last) * self._time_scale, now
            with self._updated:
                if generation == self._mode_generation:  # else a goal has just written it
                    self._follow(raw_mode)
                self.model.step(dt_s)
                snapshot = self.model.snapshot()
                self._update_count += 1
                self._updated.notify_all()
            self._publish_state(snapshot)
            self._log_progress(snapshot)

    def _read_mode_param(self):
        try:
            return rospy.get_param(MODE_PARAM, None)
        except (ConnectionError, OSError) as error:  # master gone: keep the mode
            rospy.logwarn_throttle(10.0, 'cannot read %s: %s', MODE_PARAM, error)
            return _INVALID

    def _follow(self, raw_mode):
        mode = parse_mode(raw_mode)
        if mode is _INVALID:
            if raw_mode is not _INVALID:
                self._log_invalid_mode(raw_mode)
            return
        self._invalid_logged = (None, 0.0)
        self.model.set_mode(mode)

    def _log_invalid_mode(self, raw_mode):
        """An error at once for each new bad value, then every INVALID_LOG_PERIOD_S while it stays."""
        value, logged_at = self._invalid_logged
        now = time.monotonic()
        if value == repr(raw_mode) and now - logged_at < INVALID_LOG_PERIOD_S:
            return
        self._invalid_logged = (repr(raw_mode), now)
        rospy.logerr('%s = %r is invalid: must be 1/true (charge), 0/false (discharge) or unset '
                     '(hold); keeping %s', rospy.resolve_name(MODE_PARAM), raw_mode, self.model.mode.value)

    def _publish_state(self, snapshot):
        self._state_pub.publish(to_battery_state(snapshot, self.params, stamp=rospy.Time.now()))

    def _log_progress(self, snapshot):
        whole = int(snapshot.percentage)
        logged_percent, logged_at = self._logged
        now = time.monotonic()
        if whole != logged_percent and now - logged_at >= 1.0:
            self._logged = (whole, now)
            rospy.loginfo('%s... %d %% (%.2f V, %+.2f A)', snapshot.status.value.capitalize(),
                          whole, snapshot.voltage_v, snapshot.current_a)

    # -- goals (actionlib's thread) ---------------------------------------------

    def _execute(self, goal):
        mode = Mode.CHARGE if goal.charge_state else Mode.DISCHARGE
        target, done_text = (Status.FULL, 'Full') if goal.charge_state else (Status.EMPTY, 'Empty')
        with self._updated:
            self._mode_generation += 1
            rospy.set_param(MODE_PARAM, 1 if goal.charge_state else 0)
            self.model.set_mode(mode)
            snapshot = self.model.snapshot()
            seen = self._update_count
        rospy.loginfo('goal: %s from %.1f %%', mode.value, snapshot.percentage)
        while True:
            self._server.publish_feedback(battery_simFeedback(battery_percentage=snapshot.percentage))
            if snapshot.status is target:
                self._server.set_succeeded(battery_simResult(battery_status=done_text))
                rospy.loginfo('goal succeeded: %s', done_text)
                return
            if snapshot.mode is not mode:
                text = 'Aborted at %.1f %%: %s was changed to %s while %s' % (
                    snapshot.percentage, rospy.resolve_name(MODE_PARAM), snapshot.mode.value, mode.value)
                self._server.set_aborted(battery_simResult(battery_status=text), text)
                rospy.logwarn('%s', text)
                return
            if self._server.is_preempt_requested() or self._stopping.is_set() or rospy.is_shutdown():
                text = self._preempted_text(snapshot)
                self._server.set_preempted(battery_simResult(battery_status=text), text)
                rospy.loginfo('%s', text)
                return
            with self._updated:
                if self._update_count == seen and not self._stopping.is_set():
                    self._updated.wait(FEEDBACK_PERIOD_S)
                snapshot, seen = self.model.snapshot(), self._update_count

    def _preempted_text(self, snapshot):
        if self._stopping.is_set() or rospy.is_shutdown():
            reason = 'server shutting down'
        elif self._server.is_new_goal_available():
            reason = 'a new goal'
        else:
            reason = 'cancel'
        return 'Preempted at %.1f %% (%s, %s)' % (snapshot.percentage, reason, snapshot.status.value)


def main():
    rospy.init_node('BatterySimServer')
    try:
        settings = read_settings()
    except StartupError as error:
        exit_on_startup_error(error)
    BatterySimServer(**settings).start()
    rospy.spin()
