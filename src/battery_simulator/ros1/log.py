"""Log lines of one battery among many through rospy (core/battery_log.py: the name in front, throttled
per robot; ros2/log.py's twin)."""
import rospy

from battery_simulator.core.battery_log import BatteryLog


class RobotLog(BatteryLog):
    """rospy's log functions for one battery: ``prefix`` (e.g. ``'robot3: '``) before every line; the progress
    lines only when ``progress`` (a single battery's node: a fleet host logs none)."""

    def __init__(self, prefix='', progress=False):
        super().__init__(rospy.loginfo, rospy.logwarn, rospy.logerr, prefix, progress)
