"""battery_state_pub's rule over the battery's latest state, for both front ends (no ROS import).

What goes out on ``battery_status`` at a tick: nothing before the first state,
nothing while the sensor_dropout fault holds, else the latest state, which is
stale (and said so, throttled) once no update came for ``stale_timeout_s``;
when updates come again that is said once.
"""
import time


class LatestState:
    """The latest state (a record or a received message: ``sensor_dropout`` is all it reads) and when it came."""

    def __init__(self, stale_timeout_s, log, waiting_for, source, clock=time.monotonic):
        """``log``: info/warn and their ``*_throttle`` forms; ``waiting_for``: what a line before the first
        state names; ``source``: where the states come from, in the stale line."""
        self._source = source
        self._stale_timeout_s = stale_timeout_s
        self._log = log
        self._waiting_for = waiting_for
        self._clock = clock
        self.latest = None
        self._received_at = 0.0
        self._said_stale = False

    def take(self, state):
        self.latest, self._received_at = state, self._clock()

    def stale(self):
        """Whether no update came for longer than the stale timeout."""
        return self._clock() - self._received_at > self._stale_timeout_s

    def to_publish(self):
        """The state to publish now, or None (no state yet, or a sensor dropout), with the lines that say why."""
        latest = self.latest
        if latest is None:
            self._log.info_throttle(10.0, 'waiting for %s', self._waiting_for)
            return None
        if latest.sensor_dropout:
            self._log.warn_throttle(10.0, 'sensor_dropout fault active: battery_status withheld')
            return None
        age_s = self._clock() - self._received_at
        if age_s > self._stale_timeout_s:
            self._log.warn_throttle(10.0, 'battery state is stale: no update from %s for %.0f s; '
                                    'republishing the last known state', self._source, age_s)
            self._said_stale = True
        elif self._said_stale:
            self._log.info('battery state updates resumed')
            self._said_stale = False
        return latest
