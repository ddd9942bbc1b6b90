"""Log lines of one battery among many: the robot's name in front, throttled per robot.

rospy's *_throttle keys its throttle by the line of code, so in a fleet host
one robot's line would silence every other robot's. This keys it by robot
(this object) and message.
"""
import time

import rospy


class RobotLog:
    """rospy's log functions for one battery: ``prefix`` (e.g. ``'robot3: '``) before every line."""

    def __init__(self, prefix='', progress=True):
        self.prefix = prefix
        self._progress = progress   # a fleet host logs no level-by-level progress (hundreds of robots would flood /rosout)
        self._last = {}   # (level, format) -> monotonic time last logged

    def progress(self, text, *args):
        """A progress line (the level as it moves): info for one battery, nothing in a fleet host."""
        if self._progress:
            rospy.loginfo(self.prefix + text, *args)

    def info(self, text, *args):
        rospy.loginfo(self.prefix + text, *args)

    def warn(self, text, *args):
        rospy.logwarn(self.prefix + text, *args)

    def error(self, text, *args):
        rospy.logerr(self.prefix + text, *args)

    def info_throttle(self, period_s, text, *args):
        self._throttled(rospy.loginfo, period_s, text, args)

    def warn_throttle(self, period_s, text, *args):
        self._throttled(rospy.logwarn, period_s, text, args)

    def error_throttle(self, period_s, text, *args):
        self._throttled(rospy.logerr, period_s, text, args)

    def _throttled(self, log, period_s, text, args):
        now = time.monotonic()
        key = (log, text)
        if now - self._last.get(key, -period_s) >= period_s:
            self._last[key] = now
            log(self.prefix + text, *args)
