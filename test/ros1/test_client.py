#!/usr/bin/python3
"""rostest: battery_sim_client.py exit codes and its effect on the server."""
import os
import select
import signal
import subprocess
import time
import unittest

import rospy
import rostest
from rosgraph_msgs.msg import Log
from sensor_msgs.msg import BatteryState

from battery_simulator.srv import SetState

from rostest_helpers import Recorder, SetStateProxy, node_command, stop_process, wait_for

#: a server this test starts itself, and its client, wait this long for it: on a busy machine its start took more
#: than the client's default 10 s (a fresh-clone run with two CPU hogs: no goal, 'timed out ... the goal running')
SERVER_START_S = 60.0
CLIENT = node_command('battery_sim_client.py')
ROSRUN_CLIENT = ['rosrun', 'battery_simulator', 'battery_sim_client.py']   # as a user types it
NAN = float('nan')


def run_client(*args, timeout_s=90.0, command=CLIENT):
    result = subprocess.run(command + list(args), capture_output=True, text=True, timeout=timeout_s)
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
        self.put_at(90.0)   # goals start near their ends
        code, out, err = run_client('1', command=ROSRUN_CLIENT)
        self.assertEqual(code, 0, out + err)
        self.assertIn('Result: Full', out)
        self.assertIn('%', out, 'progress is shown')
        self.put_at(10.0)
        code, out, err = run_client('discharge')
        self.assertEqual(code, 0, out + err)
        self.assertIn('Result: Empty', out)

    def test_bad_argument_prints_usage_and_sends_no_goal(self):
        before = self.log.count()
        for bad in (['2'], ['yes'], []):
            code, out, err = run_client(*bad)
            self.assertEqual(code, 2, 'exit code for %r' % bad)
            self.assertIn('usage', err.lower())
        self.put_at(95.0)
        code, _, _ = run_client('charge')   # the goal topic does see a real goal
        self.assertEqual(code, 0)
        wait_for(lambda: self.goals_since(before), 10.0, 'the server to log the good goal')
        goals = self.goals_since(before)
        self.assertEqual(len(goals), 1, 'only the good goal reached the server: %s' % goals)
        self.assertIn('charge', goals[0])

    def put_at(self, percentage):
        """Discharging at ``percentage`` (set_state: whatever earlier tests left)."""
        rospy.set_param('MyRobot/BatteryStatus', 0)
        rospy.wait_for_service('battery_simulator/set_state', 30.0)
        self.assertTrue(SetStateProxy('battery_simulator/set_state')(percentage, NAN, NAN).success)
        self.status.wait_until(lambda m: m.current < 0 and m.percentage <= percentage / 100.0, 30.0,
                               'discharging at %g %%' % percentage)

    def test_abort_and_timeout_exit_non_zero(self):
        self.put_at(55.0)
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
        self.put_at(30.0)
        code, out, err = run_client('1', '--timeout', '0.5')
        self.assertEqual(code, 4, out + err)
        self.assertIn('timed out', out)


    def start_server(self, namespace):
        """A server of our own (no respawn), 80 %, real time: goals run long."""
        env = dict(os.environ, ROS_NAMESPACE=namespace)
        server = subprocess.Popen(node_command('battery_sim_server.py') + ['__name:=BatterySimServer',
                                   '_time_scale:=1', '_initial_percentage:=80'], env=env,
                                  stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
        self.addCleanup(stop_process, server)
        return server

    def start_client(self, namespace, *args):
        env = dict(os.environ, ROS_NAMESPACE=namespace)
        client = subprocess.Popen(CLIENT + list(args), env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                  text=True, start_new_session=True)
        self.addCleanup(stop_process, client, signal.SIGKILL)
        return client

    def wait_goal_running(self, logged, namespace):
        self.log.wait_new(logged, lambda m: m.msg.startswith('goal: charge') and m.name.startswith('/' + namespace),
                          SERVER_START_S + 10.0, 'the goal running on /%s' % namespace)

    def test_sigterm_cancels_the_goal_like_ctrl_c(self):
        self.start_server('term')
        logged = self.log.count()
        client = self.start_client('term', '1', '--server-timeout', str(SERVER_START_S))
        self.wait_goal_running(logged, 'term')
        client.send_signal(signal.SIGTERM)
        out, err = client.communicate(timeout=30.0)
        self.assertEqual(client.returncode, 130, out + err)
        self.assertNotIn('Traceback', err)
        self.log.wait_new(logged, lambda m: 'Preempted' in m.msg and 'cancel' in m.msg, 10.0,
                          'the server preempting the cancelled goal')

    def test_ctrl_c_after_the_server_died_ends_the_client_within_2_s(self):
        """The cancel's wait for an answer is bounded (cli/interrupt.py CANCEL_WAIT_S): a killed server never answers
        (ROS 2's twin: test/ros2/test_hardening_timing.py; it took 5.7 s with a 5 s wait)."""
        server = self.start_server('ctrlc')
        logged = self.log.count()
        client = self.start_client('ctrlc', '1', '--server-timeout', str(SERVER_START_S))
        self.wait_goal_running(logged, 'ctrlc')
        os.killpg(server.pid, signal.SIGKILL)
        server.wait(10.0)
        interrupted_at = time.monotonic()
        client.send_signal(signal.SIGINT)
        out, err = client.communicate(timeout=30.0)
        self.assertEqual(client.returncode, 130, out + err)
        self.assertLess(time.monotonic() - interrupted_at, 2.0, 'Ctrl-C took more than 2 s:\n' + out + err)

    def test_a_server_that_dies_mid_goal_ends_the_client_with_1(self):
        server = self.start_server('lost')
        logged = self.log.count()
        client = self.start_client('lost', '1', '--server-timeout', str(SERVER_START_S))
        self.wait_goal_running(logged, 'lost')
        os.killpg(server.pid, signal.SIGKILL)
        killed_at = time.monotonic()
        out, err = client.communicate(timeout=30.0)
        self.assertEqual(client.returncode, 1, out + err)
        self.assertIn('lost the action server', err)
        self.assertLess(time.monotonic() - killed_at, 10.0, 'noticed within a few seconds')

    def test_ctrl_c_while_waiting_for_the_server_prints_no_traceback(self):
        client = self.start_client('nowhere', '1', '--server-timeout', '60')
        ready, _, _ = select.select([client.stderr], [], [], 30.0)
        self.assertTrue(ready, 'the client said nothing while waiting')
        self.assertIn('waiting for the action server', client.stderr.readline())
        client.send_signal(signal.SIGINT)
        out, err = client.communicate(timeout=30.0)
        self.assertEqual(client.returncode, 130, out + err)
        self.assertNotIn('Traceback', err)

    def test_ctrl_c_while_starting_up_prints_no_traceback(self):
        # -X importtime reports each finished import on stderr: interrupt while the ROS imports still run
        client = subprocess.Popen(['/usr/bin/python3', '-X', 'importtime'] + CLIENT + ['1'], stdout=subprocess.PIPE,
                                  stderr=subprocess.PIPE, text=True, start_new_session=True)
        self.addCleanup(stop_process, client, signal.SIGKILL)
        imported = []
        while 'numpy' not in imported:   # numpy comes with genpy, before actionlib and the messages
            ready, _, _ = select.select([client.stderr], [], [], 30.0)
            self.assertTrue(ready, 'no import report within 30 s')
            line = client.stderr.readline()
            self.assertTrue(line, 'the client ended before importing numpy')
            imported.append(line.rsplit('|', 1)[-1].strip())
        client.send_signal(signal.SIGINT)
        out, err = client.communicate(timeout=30.0)
        self.assertEqual(client.returncode, 130, out + err)
        self.assertNotIn('Traceback', err)

    def test_no_master_exits_3_within_the_server_timeout(self):
        env = dict(os.environ, ROS_MASTER_URI='http://127.0.0.1:9')   # nothing listens on the discard port
        started = time.monotonic()
        result = subprocess.run(CLIENT + ['1', '--server-timeout', '2'], env=env, capture_output=True, text=True,
                                timeout=30.0)
        self.assertEqual(result.returncode, 3, result.stdout + result.stderr)
        self.assertIn('no ROS master', result.stderr)
        self.assertLess(time.monotonic() - started, 10.0)

    def test_bad_timeouts_are_usage_errors(self):
        for bad in (['--timeout', 'nan'], ['--timeout', 'inf'], ['--timeout', '-1'],
                    ['--server-timeout', 'nan'], ['--server-timeout', '-1']):
            code, out, err = run_client('1', *bad)
            self.assertEqual(code, 2, 'exit code for %r' % bad)
            self.assertIn('usage', err.lower())
            self.assertNotIn('Traceback', err)


if __name__ == '__main__':
    rostest.rosrun('battery_simulator', 'client', TestClient)
