#!/usr/bin/python3
"""rostest: demo.launch runs PATROL -> GO_TO_DOCK -> CHARGING -> UNDOCK -> PATROL
with the battery never empty (test/demo.test: time_scale 240, speed 0.6 m/s)."""
import unittest

import rospy
import rostest
from nav_msgs.msg import Odometry
from std_msgs.msg import String

from battery_simulator.msg import BatterySimState
from rostest_helpers import Recorder, wait_for

CYCLE = ['PATROL', 'GO_TO_DOCK', 'CHARGING', 'UNDOCK', 'PATROL']


class TestDemo(unittest.TestCase):

    def test_one_whole_cycle_without_running_empty(self):
        rospy.init_node('test_demo')
        phases = Recorder('patrol_and_dock/phase', String)
        state = Recorder('battery_simulator/state', BatterySimState)
        odom = Recorder('odom', Odometry)
        wait_for(lambda: len(phases.since(0)) >= len(CYCLE), 150.0, 'one whole cycle of phases')
        seen = [m.data for m in phases.since(0)][:len(CYCLE)]
        self.assertEqual(seen, CYCLE)
        states = [m.charging_state for m in state.since(0)]
        self.assertNotIn('Empty', states, 'the battery ran empty')
        self.assertIn('Charging', states)
        self.assertIn('Full', states)
        self.assertGreater(len({round(m.pose.pose.position.x, 1) for m in odom.since(0)}), 5, 'the robot moved')


if __name__ == '__main__':
    rostest.rosrun('battery_simulator', 'demo', TestDemo)
