"""Elapsed simulated time from a clock that may start late or jump (no rospy).

A ROS node under /use_sim_time sees time 0 until the first /clock message,
then whatever the simulator or rosbag says: 1.7e9 s for a bag recorded
today, a jump backwards on every simulator reset or bag loop, and, when a
second /clock publisher interleaves its times with the first (sim_clock beside
Gazebo), jumps back and forth of hours. The battery must age by the time that
passes while it runs, not by those jumps.
"""


class TimeBase:
    """Turns readings of a clock into elapsed seconds, scaled by ``time_scale``.

    The first valid reading is a starting point, not elapsed time. A reading
    earlier than the previous one restarts the base (nothing elapses for the
    jump); so does one more than ``max_jump_s`` after it (None: no bound). A
    reading of 0 under sim time means "no clock yet" and is skipped.
    """

    def __init__(self, time_scale=1.0, zero_is_unset=False, max_jump_s=None):
        self.time_scale = time_scale
        self.max_jump_s = max_jump_s
        self._zero_is_unset = zero_is_unset
        self._last = None
        self.jumps_back = 0      # backward jumps seen
        self.jumps_forward = 0   # forward jumps beyond max_jump_s seen

    @property
    def restarts(self):
        """Restarts of the base so far (jumps either way)."""
        return self.jumps_back + self.jumps_forward

    def elapsed(self, now):
        """Scaled seconds since the previous call's reading (0 on a start or a restart)."""
        if self._zero_is_unset and now <= 0.0:
            return 0.0
        last, self._last = self._last, now
        if last is None:
            return 0.0
        if now < last:
            self.jumps_back += 1
            return 0.0
        if self.max_jump_s is not None and now - last > self.max_jump_s:
            self.jumps_forward += 1
            return 0.0
        return (now - last) * self.time_scale

    def pending(self, now):
        """Scaled seconds from the previous reading to ``now``, without taking ``now`` as a reading
        (what the next ``elapsed(now)`` would return, 0 where it would return 0)."""
        if (self._zero_is_unset and now <= 0.0) or self._last is None or now < self._last or \
                (self.max_jump_s is not None and now - self._last > self.max_jump_s):
            return 0.0
        return (now - self._last) * self.time_scale
