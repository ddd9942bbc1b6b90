#!/usr/bin/python3
"""rostest: a pack of differing groups and a fuel gauge that can be wrong (interface Part 5), on ROS 1:
cell arrays per group, the gauge's view on battery_status and the truth on battery_simulator/state,
set_state's gauge_error, the fault gauge_stuck, the cell diagnostics. Part 9 in the namespace learning: a
learning gauge (gauge_config) reads a rest, logs the correction once and counts it in the diagnostics."""
import math
import re
import time
import unittest

import rospy
import rostest
from diagnostic_msgs.msg import DiagnosticArray
from rosgraph_msgs.msg import Log
from sensor_msgs.msg import BatteryState

from battery_simulator.msg import BatterySimState
from battery_simulator.srv import InjectFault
from rostest_helpers import Recorder, SetStateProxy, wait_for

NAN = math.nan


class TestGauge(unittest.TestCase):

    @classmethod
    def setUpClass(cls):
        rospy.init_node('test_gauge')
        cls.status = Recorder('battery_status', BatteryState)
        cls.state = Recorder('battery_simulator/state', BatterySimState)
        cls.diagnostics = Recorder('/diagnostics', DiagnosticArray)
        cls.set_state = SetStateProxy('battery_simulator/set_state')
        cls.set_state.wait_for_service(20.0)
        cls.inject = rospy.ServiceProxy('battery_simulator/inject_fault', InjectFault)
        cls.rosout = Recorder('/rosout', Log)
        cls.learning_state = Recorder('learning/battery_simulator/state', BatterySimState)
        cls.learning_set_state = SetStateProxy('learning/battery_simulator/set_state')
        cls.learning_set_state.wait_for_service(20.0)
        wait_for(lambda: cls.status.count() > 0 and cls.state.count() > 0, 30.0, 'battery_status and the state')

    def pair(self):
        """(read 0-100, true 0-100) of a state message arriving from now."""
        mark = self.state.count()
        wait_for(lambda: self.state.count() > mark, 5.0, 'a new state')
        msg = self.state.latest()
        return 100.0 * msg.battery.percentage, msg.true_percentage

    def test_1_every_group_its_own_cell_voltage_and_the_cell_diagnostics(self):
        msg = self.status.latest()
        self.assertEqual(len(msg.cell_voltage), 7)
        self.assertEqual(len(msg.cell_temperature), 7)
        self.assertGreater(max(msg.cell_voltage) - min(msg.cell_voltage), 1e-4, list(msg.cell_voltage))
        def aged_status():   # the aged pack's (the namespace learning has a battery of its own)
            arrays = self.diagnostics.since(0)
            return next((s for array in reversed(arrays) for s in array.status
                         if s.name == 'battery_state_pub: Battery'), None)
        wait_for(lambda: aged_status() is not None, 10.0, 'the aged pack\'s diagnostics')
        values = {v.key: v.value for v in aged_status().values}
        self.assertGreater(float(values['Cell Imbalance (mV)']), 0.0)
        self.assertLess(float(values['Cell Voltage Min (V)']), float(values['Cell Voltage Max (V)']))

    def test_2_the_robot_reads_the_gauge_and_set_state_moves_it(self):
        read, true = self.pair()
        self.assertGreater(read, true + 1.0, 'the aged gauge starts 2 points high')
        self.assertTrue(self.set_state(percentage=60.0, gauge_error=-4.0).success)
        read, true = self.pair()
        self.assertAlmostEqual(read, true - 4.0, delta=0.3)
        refused = self.set_state(gauge_error=200.0)
        self.assertFalse(refused.success)
        self.assertIn('gauge_error', refused.message)

    def test_3_a_stuck_gauge_freezes_what_the_robot_reads(self):
        self.assertTrue(self.inject('gauge_stuck', True).success)
        try:
            read_before, true_before = self.pair()
            deadline = time.monotonic() + 10.0
            read, true = read_before, true_before
            while abs(true - true_before) <= 0.5 and time.monotonic() < deadline:
                read, true = self.pair()
            self.assertGreater(abs(true - true_before), 0.5, 'the truth moves on')
            self.assertAlmostEqual(read, read_before, delta=1e-4, msg='what the robot reads stays')
        finally:
            self.inject('gauge_stuck', False)

    def learning_values(self, predicate, timeout_s):
        """The learning battery's diagnostics values once ``predicate(values)`` holds."""
        found = []

        def seen():
            for status in self.diagnostics.latest().status if self.diagnostics.count() else ():
                if status.name == 'learning/battery_state_pub: Battery':
                    values = {v.key: v.value for v in status.values}
                    if predicate(values):
                        found.append(values)
                        return True
            return False
        wait_for(seen, timeout_s, 'the learning gauge\'s diagnostics')
        return found[-1]

    def test_4_a_learning_gauge_reads_a_rest_logs_the_correction_once_and_counts_it(self):
        values = self.learning_values(lambda v: 'Gauge Corrections' in v, 10.0)
        self.assertEqual((values['Gauge Corrections'], values['Gauge Learned']), ('0', 'false'))
        self.assertAlmostEqual(float(values['Gauge Full Capacity (Ah)']), 2.781, delta=1e-3)
        self.assertTrue(self.learning_set_state(percentage=50.0, gauge_error=5.0).success)
        mark = self.learning_state.count()
        wait_for(lambda: self.learning_state.count() > mark, 5.0, 'a new state')
        msg = self.learning_state.latest()
        self.assertAlmostEqual(100.0 * msg.battery.percentage, msg.true_percentage + 5.0, delta=0.3)
        # 30 min of battery at x500: 3.6 s; then read every 100 s (0.2 s): one correction
        self.learning_values(lambda v: v.get('Gauge Corrections') == '1', 30.0)
        msg = self.learning_state.latest()
        self.assertLessEqual(abs(100.0 * msg.battery.percentage - msg.true_percentage), 1.0)
        self.assertEqual((msg.gauge_corrections, msg.gauge_learned), (1, False))

        def logged():
            return [m.msg for m in self.rosout.since(0) if 'gauge ocv_rest' in m.msg]
        wait_for(lambda: logged(), 5.0, 'the correction in the log')
        line = re.match(r'gauge ocv_rest: ([\d.]+) % -> ([\d.]+) % \(rest of \d+ min', logged()[0])
        old, new = map(float, line.groups())
        self.assertTrue(4.0 <= old - new <= 7.0, logged())   # the 5 points, and the hysteresis' 0.65
        time.sleep(1.0)   # more rest readings (every 0.2 s): none of them a correction to log
        self.assertEqual(len(logged()), 1, logged())


if __name__ == '__main__':
    rostest.rosrun('battery_simulator', 'gauge', TestGauge)
