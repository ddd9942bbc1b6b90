#!/usr/bin/python3
"""rostest: a server whose model worker dies (a fault planted in the model's step,
test/ros1/planted_fault_server.py) ends with one FATAL line and a non-zero exit
instead of serving a frozen state for ever; respawned, it resumes within 1 %."""
import unittest

import rospy
import rostest
from rosgraph_msgs.msg import Log

from battery_simulator.msg import BatterySimState
from rostest_helpers import Recorder, wait_for


class TestWorkerCrash(unittest.TestCase):

    @classmethod
    def setUpClass(cls):
        rospy.init_node('test_worker_crash')
        cls.state = Recorder('battery_simulator/state', BatterySimState)
        cls.log = Recorder('/rosout', Log)

    def test_a_dead_worker_ends_the_node_which_respawns_and_resumes(self):
        server = rospy.resolve_name('BatterySimServer')
        fatal = self.log.wait_new(0, lambda m: m.name == server and m.level == Log.FATAL, 60.0,
                                  'the FATAL line of the server whose worker died')
        self.assertIn('planted fault', fatal.msg)
        self.assertIn('ending the node', fatal.msg)
        last = self.state.latest()
        seen = self.state.count()
        self.log.wait_new(0, lambda m: m.name == server and 'resumed' in m.msg, 30.0, 'the respawned server resuming')
        fatal_lines = [m for m in self.log.since(0) if m.name == server and m.level == Log.FATAL]
        self.assertEqual(len(fatal_lines), 1, [m.msg for m in fatal_lines])
        resumed = self.state.next_after(seen, 30.0)
        self.assertLess(abs(resumed.battery.percentage - last.battery.percentage), 0.01,
                        'resumed at %.2f %% after %.2f %%' % (100 * resumed.battery.percentage,
                                                              100 * last.battery.percentage))
        wait_for(lambda: self.state.count() > seen + 5, 10.0, 'the respawned server updating')


if __name__ == '__main__':
    rostest.rosrun('battery_simulator', 'worker_crash', TestWorkerCrash)
