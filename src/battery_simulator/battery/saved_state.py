"""Where the server keeps the battery's state across a crash or a restart.

Two places: the private parameter ``~saved_state`` (the parameter server
outlives a respawned node; sim.launch clears it with ``clear_params`` on a
fresh launch) and, when ``~state_file`` is set, a JSON file (ageing carried
across runs). Writes are throttled: often enough to resume within a fraction
of a percent, rare enough to cost nothing.
"""
import json
import os
import time

import rospy

SAVED_STATE_PARAM = '~saved_state'
SAVE_EVERY_PERCENT = 0.1   # save when the level moved this much ...
SAVE_EVERY_S = 2.0         # ... or this long (wall) has passed
FILE_EVERY_S = 10.0        # the state file is written at most this often, and at shutdown


class StateStore:
    """Saves ``model.export_state()`` to the parameter server and an optional file."""

    def __init__(self, state_file=''):
        self.state_file = state_file
        self._saved = (None, 0.0)      # (percentage, wall time) of the last parameter write
        self._file_saved_at = 0.0

    def load(self):
        """(saved state, where from) or (None, None): the parameter first, then the file."""
        saved = rospy.get_param(SAVED_STATE_PARAM, None)
        if saved is not None:
            return saved, 'the parameter server (%s)' % rospy.resolve_name(SAVED_STATE_PARAM)
        if self.state_file and os.path.exists(self.state_file):
            try:
                with open(self.state_file, encoding='utf-8') as stream:
                    return json.load(stream), self.state_file
            except (OSError, ValueError) as error:
                rospy.logwarn('cannot read state file %s (%s): starting fresh', self.state_file, error)
        return None, None

    def maybe_save(self, state):
        """Save if the level moved or time passed since the last save (called every update)."""
        percentage, saved_at = self._saved
        now = time.monotonic()
        level = 100.0 * state['state_of_charge']
        if percentage is None or abs(level - percentage) >= SAVE_EVERY_PERCENT or now - saved_at >= SAVE_EVERY_S:
            self._save_param(state, level, now)
        if self.state_file and now - self._file_saved_at >= FILE_EVERY_S:
            self._save_file(state, now)

    def save_now(self, state):
        """At shutdown: both places, whatever the throttles say."""
        self._save_param(state, 100.0 * state['state_of_charge'], time.monotonic())
        if self.state_file:
            self._save_file(state, time.monotonic())

    def _save_param(self, state, level, now):
        try:
            rospy.set_param(SAVED_STATE_PARAM, state)
            self._saved = (level, now)
        except (ConnectionError, OSError) as error:  # master gone: try again next update
            rospy.logwarn_throttle(10.0, 'cannot save the battery state: %s', error)

    def _save_file(self, state, now):
        self._file_saved_at = now
        temporary = self.state_file + '.tmp'
        try:
            with open(temporary, 'w', encoding='utf-8') as stream:
                json.dump(state, stream, indent=1)
            os.replace(temporary, self.state_file)   # never a half-written file
        except OSError as error:
            rospy.logerr_throttle(60.0, 'cannot write state file %s: %s', self.state_file, error)
