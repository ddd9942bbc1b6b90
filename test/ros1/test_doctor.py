#!/usr/bin/python3
"""rostest: battery_doctor.py beside a live ROS 1 graph (doctor.test: sim.launch in robot1).

Clean with the battery and a TwistStamped cmd_vel publisher (exit 0); then eight planted faults (ROS 1 has
no QoS), each named on a 'problem:' line of its own, and a stopped node's battery topic on the 'unsampled:'
line (exit 1)."""
import os
import signal
import subprocess
import sys
import unittest

import rospy
import rostest
from sensor_msgs.msg import BatteryState

from rostest_helpers import node_command, stop_process, wait_for

HERE = os.path.dirname(os.path.abspath(__file__))


def run_doctor(*args, timeout_s=40.0):
    process = subprocess.Popen(node_command('battery_doctor.py') + list(args), stdout=subprocess.PIPE,
                               stderr=subprocess.STDOUT, text=True, start_new_session=True)
    try:
        output, _ = process.communicate(timeout=timeout_s)
    except subprocess.TimeoutExpired:
        stop_process(process)
        raise AssertionError('battery_doctor.py did not end within %g s' % timeout_s)
    return process.returncode, output


def problems(output):
    return [line for line in output.splitlines() if line.startswith('problem:')]


def plant(name, *specs):
    process = subprocess.Popen([sys.executable, os.path.join(HERE, 'doctor_planted.py'), name] + list(specs),
                               stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
    wait_for(lambda: rospy.has_param('/%s/ready' % name), 20.0, '%s to start' % name)
    return process


class TestDoctor(unittest.TestCase):

    def test_1_clean_then_2_planted(self):
        first = rospy.wait_for_message('/robot1/battery_status', BatteryState, timeout=30.0)
        self.assertTrue(0.0 <= first.percentage <= 1.0, first)
        # Nav2 Kilted's TwistStamped cmd_vel: the battery takes either type (rospy.AnyMsg, reported as '*')
        nav2 = plant('nav2_kilted', 'pub,topic=/robot1/cmd_vel,type=TwistStamped')
        try:
            code, output = run_doctor('--sample', '2')
        finally:
            stop_process(nav2)
        self.assertEqual(code, 0, 'a battery driven by a TwistStamped publisher is not clean:\n' + output)
        self.assertFalse(problems(output), output)
        self.assertIn('publisher   /robot1/battery_status  sensor_msgs/BatteryState  /robot1/battery_state_pub',
                      output)
        self.assertIn('QoS (ROS 1: no QoS)', output)

        planted = [
            plant('planted_a',
                  'pub,topic=/r7/battery_status,type=BatteryState',
                  'pub,topic=/r2/cmd_vel,type=TwistStamped',
                  'pub,topic=/r4/battery_status,type=BatteryState,percentage=85',
                  'pub,topic=/r5/battery_status,type=BatteryState,current=-2.0,status=1',
                  'pub,topic=/r6/battery_status,type=BatteryState',
                  # issue 40 item 4: a NaN voltage, a percentage of -1, a publisher that went silent
                  'pub,topic=/r9/battery_status,type=BatteryState,voltage=nan',
                  'pub,topic=/r10/battery_status,type=BatteryState,percentage=-1',
                  'pub,topic=/r11/battery_status,type=BatteryState,silent_after=2'),
            plant('planted_b',
                  'sub,topic=/r7/battery_state,type=BatteryState',
                  'sub,topic=/r2/cmd_vel,type=Twist',
                  'pub,topic=/r6/battery_status,type=BatteryState'),
            # a node that answers nothing (stopped): its battery topic cannot be heard, and is listed unsampled
            plant('planted_c', 'pub,topic=/r12/battery_status,type=BatteryState')]
        os.kill(planted[2].pid, signal.SIGSTOP)
        try:
            code, output = run_doctor('--sample', '3')
        finally:
            os.kill(planted[2].pid, signal.SIGCONT)
            for process in planted:
                stop_process(process)
        found = problems(output)
        self.assertEqual(code, 1, output)
        expected = {
            'unpublished': ('problem: /r7/battery_state:', '/planted_b',
                            'remap /r7/battery_state:=/r7/battery_status'),
            'type': ('problem: /r2/cmd_vel:', '/planted_a publishes geometry_msgs/TwistStamped',
                     '/planted_b subscribes geometry_msgs/Twist only'),
            'percentage': ('problem: /r4/battery_status:', 'percentage 85 is above 1'),
            'sign': ('problem: /r5/battery_status:', 'current -2 A is negative', 'CHARGING'),
            'two': ('problem: /r6/battery_status:', '2 publishers publish', '/planted_a', '/planted_b'),
            'NaN voltage': ('problem: /r9/battery_status:', 'voltage NaN is out of its range'),
            'percentage -1': ('problem: /r10/battery_status:', 'percentage -1 is below 0'),
            'silent': ('problem: /r11/battery_status:', '/planted_a sent nothing in', 'went silent'),
        }
        missing = sorted(kind for kind, words in expected.items()
                         if len([line for line in found if all(word in line for word in words)]) != 1)
        self.assertFalse(missing, 'not named once each: %s\n%s' % (missing, output))
        self.assertEqual(len(found), len(expected), 'unexpected findings:\n' + output)
        unsampled = [line for line in output.splitlines() if line.startswith('unsampled:')]
        self.assertEqual(len(unsampled), 1, output)
        self.assertIn('/r12/battery_status (not connected to every publisher)', unsampled[0])
        self.assertNotIn('/r11/', unsampled[0])
        self.assertNotIn('no problems found', output)


    def test_3_a_node_still_serving_the_doctors_connections_is_not_called_silent(self):
        """Issue 40 item 4: a fleet host of 100 robots on a busy machine sent nothing for seconds on some of the
        doctor's 200 new connections while it served the others, and they were called silent. One node whose
        topic K sends only 0.5 x K s after the doctor connected (the last 4.5 s after): every topic of it
        sampled, none called silent (before: those from 3 s on were)."""
        topics = ['/lag/robot%d/battery_status' % k for k in range(10)]
        process = plant('lagging_host', *['pub,topic=%s,type=BatteryState,lag=%g' % (topic, 0.5 * k)
                                          for k, topic in enumerate(topics)])
        try:
            code, output = run_doctor('--sample', '3')
        finally:
            stop_process(process)
        named = [line for line in problems(output) + [l for l in output.splitlines() if l.startswith('unsampled:')]
                 if '/lag/' in line]
        self.assertEqual(named, [], output)
        for topic in topics:
            self.assertRegex(output, r'(?m)^sampled +%s ' % topic, output)

if __name__ == '__main__':
    rospy.init_node('test_doctor')
    rostest.rosrun('battery_simulator', 'doctor', TestDoctor)
