#!/usr/bin/python3
"""rostest: battery_sim_client.py exit codes and its effect on the server."""
import subprocess
import unittest

import rospy
import rostest
from rosgraph_msgs.msg import Log
from sensor_msgs.msg import BatteryState

from rostest_helpers import Recorder, wait_for

CLIENT = ['rosrun', 'battery_simulator', 'battery_sim_client.py']


def run_client(*args, timeout_s=90.0):
    result = subprocess.run(CLIENT + list(args), capture_output=True, text=True, timeout=timeout_s)
    return result.returncode, result.stdout, result.stderr


class TestClient(unittest.TestCase):

    @classmethod
    def setUpClass(cls):
        rospy.init_node('test_client')
        cls.log = Recorder('/rosout', Log)
        cls.status = Recorder('battery_status', BatteryState)
        wait_for(lambda: cls.status.count() > 0, 30.0, 'battery_status')
        wait_for(lambda: cls.log.count() > 0, 30.0, '/rosout')

    def goals_since(self, index):
        """The server's 'goal: ...' log lines after the index-th /rosout message."""
        return [m.msg for m in self.log.since(index) if m.msg.startswith('goal: ')]

    def test_charge_then_discharge_exit_zero_with_the_result(self):
        code, out, err = run_client('1')
        self.assertEqual(code, 0, out + err)
        self.assertIn('Result: Full', out)
        self.assertIn('%', out, 'progress is shown')
        code, out, err = run_client('discharge')
        self.assertEqual(code, 0, out + err)
        self.assertIn('Result: Empty', out)

    def test_bad_argument_prints_usage_and_sends_no_goal(self):
        before = self.log.count()
        for bad in (['2'], ['yes'], []):
            code, out, err = run_client(*bad)
            self.assertEqual(code, 2, 'exit code for %r' % bad)
            self.assertIn('usage', err.lower())
        code, _, _ = run_client('charge')   # the goal topic does see a real goal
        self.assertEqual(code, 0)
        wait_for(lambda: self.goals_since(before), 10.0, 'the server to log the good goal')
        goals = self.goals_since(before)
        self.assertEqual(len(goals), 1, 'only the good goal reached the server: %s' % goals)
        self.assertIn('charge', goals[0])

    def test_abort_and_timeout_exit_non_zero(self):
        rospy.set_param('MyRobot/BatteryStatus', 0)
        self.status.wait_until(lambda m: m.current < 0 and m.percentage < 0.6, 30.0, 'below 60 %')
        before = self.log.count()
        client = subprocess.Popen(CLIENT + ['1'], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        try:
            wait_for(lambda: self.goals_since(before), 30.0, 'the client goal')
            self.status.wait_until(lambda m: m.current > 0, 10.0, 'charging')
            rospy.set_param('MyRobot/BatteryStatus', 0)
            out, err = client.communicate(timeout=30.0)
        finally:
            if client.poll() is None:
                client.kill()
                client.wait()
        self.assertEqual(client.returncode, 1, out + err)
        self.assertIn('Aborted', out)
        self.status.wait_until(lambda m: m.current < 0 and m.percentage < 0.3, 30.0, 'below 30 %')
        code, out, err = run_client('1', '--timeout', '0.5')
        self.assertEqual(code, 4, out + err)
        self.assertIn('timed out', out)


if __name__ == '__main__':
    rostest.rosrun('battery_simulator', 'client', TestClient)
