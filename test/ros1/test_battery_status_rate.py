#!/usr/bin/python3
"""rostest: battery_status at the rate launch argument (5 Hz) and at the
default 1 Hz, and the server's state at the update rate (10 Hz), measured
over the same 6 s window; the charging and config launch arguments; ~frame_id."""
import time
import unittest

import rospy
import rostest
from sensor_msgs.msg import BatteryState

from battery_simulator.msg import BatterySimState
from rostest_helpers import Recorder, wait_for

WINDOW_S = 6.0
TOPICS = (('battery_status', BatteryState, 5.0, 0.3),
          ('default_rate/battery_status', BatteryState, 1.0, 0.2),
          ('battery_simulator/state', BatterySimState, 10.0, 1.0))


class TestRates(unittest.TestCase):

    def test_each_topic_at_its_rate(self):
        rospy.init_node('test_rates')
        recorders = [Recorder(topic, msg_type) for topic, msg_type, _, _ in TOPICS]
        wait_for(lambda: all(r.count() >= 2 for r in recorders), 30.0, 'every topic publishing')
        starts = [r.count() - 1 for r in recorders]
        start_times = [r.arrival(i) for r, i in zip(recorders, starts)]
        end = time.monotonic() + WINDOW_S
        wait_for(lambda: all(r.arrival(r.count() - 1) > end for r in recorders), WINDOW_S + 10.0,
                 'a message on every topic after the %g s window' % WINDOW_S)
        for (topic, _, hz, tolerance), recorder, start, start_time in zip(TOPICS, recorders, starts, start_times):
            inside = [recorder.arrival(i) for i in range(start + 1, recorder.count()) if recorder.arrival(i) <= end]
            measured = len(inside) / (inside[-1] - start_time) if inside else 0.0
            self.assertAlmostEqual(measured, hz, delta=tolerance,
                                   msg='%s at %.2f Hz, expected %g Hz' % (topic, measured, hz))


    def test_charging_config_and_frame_id_arguments(self):
        rospy.init_node('test_rates')
        kobuki = Recorder('kobuki/battery_status', BatteryState)
        custom = Recorder('default_rate/battery_status', BatteryState)
        wait_for(lambda: kobuki.count() > 0 and custom.count() > 0, 30.0, 'both publishers')
        msg = kobuki.latest()
        self.assertEqual(msg.power_supply_status, BatteryState.POWER_SUPPLY_STATUS_CHARGING, 'charging:=true')
        self.assertGreater(msg.current, 0.0)
        self.assertEqual(len(msg.cell_voltage), 4, 'the 4S kobuki pack from the config file')
        self.assertAlmostEqual(msg.design_capacity, 4.4, places=3)
        self.assertEqual(msg.location, 'dock_test')
        self.assertEqual(custom.latest().header.frame_id, 'pack_frame')


if __name__ == '__main__':
    rostest.rosrun('battery_simulator', 'rates', TestRates)
