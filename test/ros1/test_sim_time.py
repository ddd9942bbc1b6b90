#!/usr/bin/python3
"""rostest: under /use_sim_time the model follows ROS time (time_scale is
ignored), the first /clock value is a starting point (a clock at epoch time
drains nothing), a clock that jumps back (simulator reset, rosbag --loop)
restarts the time base without stopping any node, a second clock interleaving
its times with the first (hours apart, or 600 s apart: two sim_clock
processes) drains no faster than one clock, and the client's timeouts stay
wall-clock seconds."""
import subprocess
import threading
import time
import unittest

import rospy
import rostest
from actionlib_msgs.msg import GoalStatusArray
from rosgraph_msgs.msg import Clock, Log
from sensor_msgs.msg import BatteryState

from rostest_helpers import Recorder, node_command, stop_process, wait_for

SIM_STEP_S = 0.2       # simulated seconds per /clock tick
TICK_WALL_S = 0.01     # wall seconds between ticks: sim time runs at about 20x
LOAD_A = 1.5           # the default pack's base load
EPOCH_S = 1.7e9        # where rosbag play --clock starts


class ClockPublisher(threading.Thread):
    def __init__(self):
        super().__init__(daemon=True)
        self.pub = rospy.Publisher('/clock', Clock, queue_size=10)
        self.lock = threading.Lock()
        self.now = rospy.Time(EPOCH_S)
        self.stop = threading.Event()
        self.paused = threading.Event()   # set: publishes nothing (other clocks run)

    def jump_to(self, seconds):
        with self.lock:
            self.now = rospy.Time(seconds)

    def run(self):
        while not self.stop.wait(TICK_WALL_S):
            if self.paused.is_set():
                continue
            with self.lock:
                self.now += rospy.Duration(SIM_STEP_S)
                now = self.now
            self.pub.publish(Clock(clock=now))


class TestSimTime(unittest.TestCase):

    @classmethod
    def setUpClass(cls):
        rospy.init_node('test_sim_time')
        cls.clock = ClockPublisher()
        cls.clock.start()
        cls.status = Recorder('battery_status', BatteryState)
        cls.action_status = Recorder('battery_simulator/status', GoalStatusArray)

    @classmethod
    def tearDownClass(cls):
        cls.clock.stop.set()

    def test_1_model_and_stamps_follow_ros_time_from_an_epoch_start(self):
        first = self.status.wait_until(lambda m: m.current < 0 and m.header.stamp.to_sec() > EPOCH_S + 5.0, 60.0,
                                       'a discharging state after sim t = epoch + 5 s')
        self.assertGreater(first.percentage, 0.995, 'the time from 0 to the first /clock drained the battery')
        self.assertLess(abs(first.header.stamp.to_sec() - self.clock.now.to_sec()), 5.0, 'stamped with sim time')
        later = self.status.wait_until(lambda m: m.header.stamp.to_sec() > first.header.stamp.to_sec() + 40.0,
                                       60.0, '40 more simulated seconds')
        elapsed_s = (later.header.stamp - first.header.stamp).to_sec()
        drawn_a = (first.percentage - later.percentage) * first.capacity * 3600.0 / elapsed_s
        # time_scale 1000 would give about 1500 A here
        self.assertAlmostEqual(drawn_a, LOAD_A, delta=0.3 * LOAD_A)

    def test_2_a_backward_jump_restarts_the_time_base_and_the_topic_flows_on(self):
        before = self.status.wait_until(lambda m: m.header.stamp.to_sec() > EPOCH_S, 30.0, 'a state at epoch time')
        self.clock.jump_to(1000.0)
        after = self.status.wait_until(lambda m: 1005.0 < m.header.stamp.to_sec() < 1e6, 30.0,
                                       'battery_status after the jump back')
        elapsed_s = after.header.stamp.to_sec() - 1000.0 + 5.0   # + an update (at most 2 s) before the jump
        used_ah = (before.percentage - after.percentage) * before.capacity
        self.assertLess(used_ah, LOAD_A * elapsed_s / 3600.0 * 1.5 + 1e-4, 'the jump drained or charged')
        self.assertGreaterEqual(used_ah, 0.0, 'the jump charged the battery')
        further = self.status.wait_until(lambda m: m.header.stamp.to_sec() > after.header.stamp.to_sec() + 10.0,
                                         30.0, 'battery_status still flowing 10 s later')
        self.assertLess(further.percentage, after.percentage, 'the model runs on after the jump')
        self.action_status.wait_until(lambda m: m.header.stamp.to_sec() > further.header.stamp.to_sec(), 10.0,
                                      'the action status still flowing after the jump')

    def test_4_a_second_clock_interleaving_its_times_drains_nothing(self):
        """A second /clock publisher (sim_clock beside a simulator) interleaves hours-apart times: every
        jump either way restarts the time base (forward ones beyond ~max_time_jump), with a warning
        naming both publishers; the battery drains no more than the honest clock's time."""
        log = Recorder('/rosout', Log)
        before = self.status.wait_until(lambda m: True, 10.0, 'battery_status before the intruder')
        started = time.monotonic()
        intruder = subprocess.Popen(node_command('sim_clock.py') + ['__name:=intruding_clock', '_start:=50000',
                                                                    '_speed:=10', '_tick_hz:=100'],
                                    stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
        try:
            def warnings():
                return [m.msg for m in log.since(0) if 'time base restarted' in m.msg and
                        '/clock has 2 publishers' in m.msg]
            wait_for(lambda: warnings(), 30.0, 'a warning naming both /clock publishers')
            warning = warnings()[0]
            self.assertIn('/intruding_clock', warning)
            self.assertIn(rospy.get_name(), warning)
            self.status.wait_until(lambda m: True, 10.0, 'battery_status while two clocks run')
        finally:
            stop_process(intruder)
        after = self.status.wait_until(lambda m: m.header.stamp.to_sec() < 1e4, 30.0,
                                       'battery_status on the honest clock again')
        honest_s = (time.monotonic() - started) * SIM_STEP_S / TICK_WALL_S   # at most this much honest time
        used_ah = (before.percentage - after.percentage) * before.capacity
        self.assertLess(used_ah, LOAD_A * honest_s / 3600.0 * 1.5 + 1e-3,
                        'the jumps drained the battery: %.1f %% -> %.1f %%' % (100 * before.percentage,
                                                                               100 * after.percentage))
        self.assertGreaterEqual(used_ah, -1e-4, 'the jumps charged the battery')

    def test_5_two_sim_clocks_600_s_apart_drain_no_faster_than_one(self):
        """Two sim_clock processes at the same speed, 600 s apart (below ~max_time_jump): the readings
        switch between the clocks' lines, and the battery drains as one clock alone makes it (the old
        rule counted every 600 s jump forwards: 27 points in 5 s)."""
        speed = SIM_STEP_S / TICK_WALL_S
        start_s = self.clock.now.to_sec() + 100.0
        self.clock.paused.set()
        clocks = []

        def start_clock(name, start):   # ticks at 1000 Hz (the default, as Gazebo)
            clocks.append(subprocess.Popen(
                node_command('sim_clock.py') + ['__name:=' + name, '_start:=%f' % start, '_speed:=%g' % speed],
                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True))
        try:
            start_clock('honest_clock', start_s)
            before = self.status.wait_until(lambda m: start_s < m.header.stamp.to_sec() < start_s + 500.0, 30.0,
                                            'battery_status on the honest sim_clock')
            started = time.monotonic()
            mark = self.status.count()
            start_clock('clock_600_s_ahead', start_s + 600.0)
            self.status.wait_new(mark, lambda m: start_s + 600.0 < m.header.stamp.to_sec() < start_s + 1e4, 30.0,
                                 'battery_status stamped on the clock 600 s ahead')
            wait_for(lambda: time.monotonic() - started > 8.0, 10.0, '8 s of two clocks')
            after = self.status.wait_until(lambda m: m.header.stamp.to_sec() > start_s, 10.0,
                                           'battery_status on the two clocks, 8 s later')
            wall_s = time.monotonic() - started + 2.0   # + an update period either side
        finally:
            for clock in clocks:
                stop_process(clock)
            self.clock.jump_to(start_s + 2000.0)
            self.clock.paused.clear()
        one_clock_ah = LOAD_A * wall_s * speed / 3600.0
        used_ah = (before.percentage - after.percentage) * before.capacity
        self.assertLess(used_ah, one_clock_ah * 1.5 + 1e-3,
                        'two clocks 600 s apart drained %.2f points in %.0f s (one clock: %.2f points)'
                        % (100.0 * (before.percentage - after.percentage), wall_s,
                           100.0 * one_clock_ah / before.capacity))
        self.assertGreaterEqual(used_ah, -1e-4, 'the jumps charged the battery')

    def test_3_client_timeouts_are_wall_seconds(self):
        started = time.monotonic()
        result = subprocess.run(['rosrun', 'battery_simulator', 'battery_sim_client.py', '0', '--timeout', '3',
                                 '--server-timeout', '10'], capture_output=True, text=True, timeout=60)
        wall_s = time.monotonic() - started
        self.assertEqual(result.returncode, 4, 'expected a timeout (4), got %d:\n%s%s'
                         % (result.returncode, result.stdout, result.stderr))
        self.assertIn('Discharging the battery', result.stdout, 'the client reached the server')
        self.assertGreater(wall_s, 2.9, 'a 3 s timeout ended after %.1f s of wall time' % wall_s)


if __name__ == '__main__':
    rostest.rosrun('battery_simulator', 'sim_time', TestSimTime)
