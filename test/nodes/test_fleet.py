#!/usr/bin/python3
"""rostest: fleet.launch n:=3 gives /robot0 ... /robot2, each its own battery, staggered."""
import unittest

import rospy
import rostest
from sensor_msgs.msg import BatteryState

from rostest_helpers import Recorder, wait_for


class TestFleet(unittest.TestCase):

    def test_three_robots_with_staggered_levels(self):
        rospy.init_node('test_fleet')
        robots = [Recorder('/robot%d/battery_status' % i, BatteryState) for i in range(3)]
        wait_for(lambda: all(r.count() > 0 for r in robots), 60.0, 'battery_status of every robot')
        levels = [r.latest().percentage for r in robots]
        for level, expected in zip(levels, (1.00, 0.95, 0.90)):
            self.assertAlmostEqual(level, expected, delta=0.005)
        self.assertFalse(rospy.has_param('/robot3/MyRobot/BatteryStatus'), 'exactly n robots')
        self.assertFalse(rospy.has_param('/MyRobot/BatteryStatus'), 'nothing in the root namespace')


if __name__ == '__main__':
    rostest.rosrun('battery_simulator', 'fleet', TestFleet)
