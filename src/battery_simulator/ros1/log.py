"""Log lines of one battery among many through rospy (core/battery_log.py: the name in front, throttled
per robot)."""
import rospy

from battery_simulator.core.battery_log import BatteryLog


class RobotLog(BatteryLog):
    """rospy's log functions for one battery: ``prefix`` (e.g. ``'robot3: '``) before every line."""

    def __init__(self, prefix='', progress=True):
        super().__init__(rospy.loginfo, rospy.logwarn, rospy.logerr, prefix, progress)
