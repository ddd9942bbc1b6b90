#!/usr/bin/python3
"""rostest: demo.launch runs PATROL -> GO_TO_DOCK -> CHARGING -> UNDOCK -> PATROL on
sim_clock (test/demo.test: speed 60, low level 50 %) with the battery never near empty
and docked within 3 points of its low level."""
import unittest

import rospy
import rostest
from nav_msgs.msg import Odometry
from std_msgs.msg import String

from battery_simulator.msg import BatterySimState
from rostest_helpers import Recorder, wait_for

CYCLE = ['PATROL', 'GO_TO_DOCK', 'CHARGING', 'UNDOCK', 'PATROL']
LOW = 0.50


class TestDemo(unittest.TestCase):

    def test_one_whole_cycle_docking_with_a_margin(self):
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
        lowest = min(m.battery.percentage for m in state.since(0))
        self.assertGreater(lowest, LOW - 0.03, 'docked at %.1f %%, more than 3 points under the low level'
                           % (100 * lowest))
        self.assertGreater(len({round(m.pose.pose.position.x, 1) for m in odom.since(0)}), 5, 'the robot moved')


if __name__ == '__main__':
    rostest.rosrun('battery_simulator', 'demo', TestDemo)
