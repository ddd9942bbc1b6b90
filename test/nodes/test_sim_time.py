#!/usr/bin/python3
"""rostest: under /use_sim_time the model follows ROS time (time_scale is
ignored) and battery_status is stamped with it."""
import threading
import unittest

import rospy
import rostest
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import BatteryState

from rostest_helpers import Recorder, wait_for

SIM_STEP_S = 0.05      # simulated seconds per /clock tick
TICK_WALL_S = 0.01     # wall seconds between ticks: sim time runs at about 5x
LOAD_A = 1.5           # the default pack's base load


class ClockPublisher(threading.Thread):
    def __init__(self):
        super().__init__(daemon=True)
        self.pub = rospy.Publisher('/clock', Clock, queue_size=10)
        self.now = rospy.Time(1000.0)
        self.stop = threading.Event()

    def run(self):
        while not self.stop.wait(TICK_WALL_S):
            self.now += rospy.Duration(SIM_STEP_S)
            self.pub.publish(Clock(clock=self.now))


class TestSimTime(unittest.TestCase):

    @classmethod
    def setUpClass(cls):
        rospy.init_node('test_sim_time')
        cls.clock = ClockPublisher()
        cls.clock.start()
        cls.status = Recorder('battery_status', BatteryState)

    @classmethod
    def tearDownClass(cls):
        cls.clock.stop.set()

    def test_model_and_stamps_follow_ros_time(self):
        first = self.status.wait_until(lambda m: m.current < 0 and m.header.stamp.to_sec() > 1005.0, 60.0,
                                       'a discharging state after sim t = 1005 s')
        self.assertLess(first.header.stamp.to_sec(), 1e6, 'stamped with sim time, not wall time')
        self.assertLess(abs(first.header.stamp.to_sec() - self.clock.now.to_sec()), 5.0)
        later = self.status.wait_until(lambda m: m.header.stamp.to_sec() > first.header.stamp.to_sec() + 40.0,
                                       60.0, '40 more simulated seconds')
        elapsed_s = (later.header.stamp - first.header.stamp).to_sec()
        used_ah = (first.percentage - later.percentage) * first.capacity
        drawn_a = used_ah * 3600.0 / elapsed_s
        # time_scale 1000 would give about 1500 A here
        self.assertAlmostEqual(drawn_a, LOAD_A, delta=0.3 * LOAD_A)


if __name__ == '__main__':
    rostest.rosrun('battery_simulator', 'sim_time', TestSimTime)
