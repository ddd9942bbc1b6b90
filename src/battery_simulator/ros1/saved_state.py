"""Where the server keeps the battery's state across a crash or a restart.

Two places: a private parameter (``~saved_state`` of battery_sim_server.py;
the parameter server outlives a respawned node; sim.launch clears it with
``clear_params`` on a fresh launch) and, when ``~state_file`` is set, a JSON
file (ageing carried across runs). Writes are throttled: often enough to
resume within a fraction of a percent, rare enough to cost nothing.

A fleet host keeps every robot's state in one parameter (FleetStore), written
at a bounded rate whatever the number of robots, so the master stays idle.
"""
import json
import threading
import time

import rospy

# the saving rule's figures are the ROS-free state file's (ROS 2 keeps its state with them too)
from battery_simulator.core.state_file import (SaveCadence, SaveThrottle, fleet_save_period_s, read_state_file,
                                               write_state_file)

FILE_EVERY_S = 10.0        # the state file is written at most this often, and at shutdown


class StateStore:
    """Saves ``model.export_state()`` to the parameter server and an optional file."""

    def __init__(self, param_name, state_file=''):
        self.param_name = param_name
        self.state_file = state_file
        self.where = None               # where load() found the state (for the resumed line)
        self._throttle = SaveThrottle()  # the parameter's writes
        self._file_saved_at = 0.0

    def load(self):
        """The saved state or None (as every keeper's load): the parameter first, then the file; ``where``
        then says which."""
        saved = rospy.get_param(self.param_name, None)
        if saved is not None:
            self.where = 'the parameter server (%s)' % self.param_name
            return saved
        try:
            saved = read_state_file(self.state_file)
        except (OSError, ValueError) as error:   # checked at start (startup.check_state_file_param): it changed
            rospy.logerr('cannot read state file %s (%s): starting fresh, and the file is never written over',
                         self.state_file, error)
            self.state_file = ''
            return None
        self.where = self.state_file if saved is not None else None
        return saved

    def maybe_save(self, state):
        """Save if SaveThrottle says so (called every update); the file at most every FILE_EVERY_S."""
        if self._throttle.due(state):
            self._save_param(state)
        now = time.monotonic()
        if self.state_file and now - self._file_saved_at >= FILE_EVERY_S:
            self._save_file(state, now)

    def save_now(self, state):
        """At shutdown: both places, whatever the throttles say."""
        self._save_param(state)
        if self.state_file:
            self._save_file(state, time.monotonic())

    def _save_param(self, state):
        try:
            rospy.set_param(self.param_name, state)
            self._throttle.wrote(state)
        except (ConnectionError, OSError) as error:  # master gone: try again next update
            rospy.logwarn_throttle(10.0, 'cannot save the battery state: %s', error)

    def _save_file(self, state, now):
        self._file_saved_at = now
        try:
            write_state_file(self.state_file, state)
        except OSError as error:
            rospy.logerr_throttle(60.0, 'cannot write state file %s: %s', self.state_file, error)


class FleetStore:
    """Every robot's saved state in one parameter (JSON text of a dict by robot name), written at most every
    fleet_save_period_s(time_scale) (0.5 s; 0.067 s at x300, so that a resume after SIGKILL is within 1 %)
    and only when a robot moved SAVE_EVERY_PERCENT (or SAVE_EVERY_S passed)."""

    def __init__(self, param_name, time_scale=1.0):
        self.param_name = param_name
        self.period_s = fleet_save_period_s(1.0 if rospy.get_param('/use_sim_time', False) else time_scale)
        self._lock = threading.Lock()
        try:
            saved = json.loads(rospy.get_param(param_name, '{}'))
        except (TypeError, ValueError):
            saved = None
        self._states = saved if isinstance(saved, dict) else {}
        self._changed = False
        self._cadence = SaveCadence(self.period_s)
        self._cadence.wrote(time.monotonic())

    def robot(self, name):
        """The store one robot's server uses (load, maybe_save, save_now)."""
        return _RobotStore(self, name)

    def write_if_due(self, force=False):
        """Write the states if any changed and the period passed (a timer calls this)."""
        with self._lock:
            now = time.monotonic()
            if not force and (not self._changed or not self._cadence.due(now)):
                return
            states, self._changed = dict(self._states), False
            self._cadence.wrote(now)
        try:
            rospy.set_param(self.param_name, json.dumps(states))   # one string: cheap for the master to store
        except (ConnectionError, OSError) as error:   # master gone: try again next time
            with self._lock:
                self._changed = True
            rospy.logwarn_throttle(10.0, 'cannot save the fleet state: %s', error)

    def _load(self, name):
        return self._states.get(name)

    def _keep(self, name, state):
        with self._lock:
            self._states[name] = state
            self._changed = True


class _RobotStore:
    def __init__(self, fleet, name):
        self._fleet, self._name = fleet, name
        self._throttle = SaveThrottle()
        self.where = 'the parameter server (%s/%s)' % (fleet.param_name, name)

    def load(self):
        return self._fleet._load(self._name)

    def maybe_save(self, state):
        if self._throttle.due(state):
            self._fleet._keep(self._name, state)
            self._throttle.wrote(state)

    def save_now(self, state):
        self._fleet._keep(self._name, state)
