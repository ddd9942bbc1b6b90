#!/usr/bin/python3
"""rostest: bad start-up values stop a node with one fatal line naming the
parameter, the value and what is allowed, and a non-zero exit."""
import itertools
import os
import signal
import subprocess
import unittest

import rospy
import rostest

from rostest_helpers import wait_for

STARTUP_TIMEOUT_S = 30.0
RUN_NUMBERS = itertools.count()


def run_node(script, *params):
    """Run a node of the package on this test's master until it exits; (exit code, output)."""
    name = 'bad_%s_%d' % (script.split('.')[0], next(RUN_NUMBERS))  # private params do not leak
    command = ['rosrun', 'battery_simulator', script, '__name:=' + name] + list(params)
    result = subprocess.run(command, capture_output=True, text=True, timeout=STARTUP_TIMEOUT_S)
    return result.returncode, result.stdout + result.stderr


class TestBadStartup(unittest.TestCase):

    def check_rejected(self, script, param, value, allowed):
        code, output = run_node(script, '_%s:=%s' % (param, value))
        self.assertNotEqual(code, 0, '%s %s:=%s exited 0:\n%s' % (script, param, value, output))
        fatal = [line for line in output.splitlines() if 'FATAL' in line]
        self.assertEqual(len(fatal), 1, 'one fatal line expected:\n%s' % output)
        self.assertIn(param, fatal[0])
        self.assertIn(value, fatal[0], 'the fatal line names the value')
        self.assertIn(allowed, fatal[0])
        self.assertNotIn('Traceback', output)

    def test_server_rejects_bad_time_scale(self):
        self.check_rejected('battery_sim_server.py', 'time_scale', '-3', 'a number > 0')

    def test_server_rejects_bad_update_rate(self):
        self.check_rejected('battery_sim_server.py', 'update_rate', 'fast', 'a number in (0, 1000] Hz')

    def test_server_rejects_bad_initial_percentage(self):
        self.check_rejected('battery_sim_server.py', 'initial_percentage', '120', 'a number in [0, 100]')

    def test_server_rejects_bad_charging(self):
        self.check_rejected('battery_sim_server.py', 'charging', 'maybe', 'true or false')

    def test_server_rejects_missing_config_file(self):
        self.check_rejected('battery_sim_server.py', 'config', '/nonexistent/battery.yaml', 'cannot read')

    def test_server_rejects_bad_yaml_value_naming_file_and_key(self):
        path = '/tmp/battery_simulator_bad_%d.yaml' % rospy.get_time()
        with open(path, 'w') as stream:
            stream.write('preset: lg_hg2_3s1p\nload_current_a: -2\n')
        self.check_rejected('battery_sim_server.py', 'config', path, 'load_current_a')
        code, output = run_node('battery_sim_server.py', '_config:=%s' % path)
        self.assertIn(path, output)
        self.assertIn('-2', output)

    def write_config(self, content):
        path = '/tmp/battery_simulator_config_%d_%d.yaml' % (os.getpid(), next(RUN_NUMBERS))
        with open(path, 'wb') as stream:
            stream.write(content)
        self.addCleanup(os.remove, path)
        return path

    def test_server_rejects_unusable_config_files_with_one_line(self):
        for content, allowed in ((b'', 'is empty'), (b'1: 2\n', 'must be text'),
                                 (b'location: "\xff"\n', 'not UTF-8'), (b'cells_series: 1000000\n', 'cells_series'),
                                 (b'load_current_a: 1000\n', 'load_current_a')):
            with self.subTest(content=content):
                self.check_rejected('battery_sim_server.py', 'config', self.write_config(content), allowed)

    def test_numbers_that_roslaunch_passes_as_text_are_accepted(self):
        name = 'text_numbers_%d' % next(RUN_NUMBERS)
        rospy.set_param('/%s/time_scale' % name, '1e9')          # as roslaunch passes time_scale:=1e9
        rospy.set_param('/%s/initial_percentage' % name, ' 50 ')
        server = subprocess.Popen(['rosrun', 'battery_simulator', 'battery_sim_server.py', '__name:=' + name],
                                  stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
        try:
            wait_for(lambda: rospy.has_param('/%s/saved_state' % name) or server.poll() is not None,
                     STARTUP_TIMEOUT_S, 'the server running')
            self.assertIsNone(server.poll(), 'the server refused numeric text (exit %s)' % server.poll())
        finally:
            if server.poll() is None:
                os.killpg(server.pid, signal.SIGINT)
                try:
                    server.wait(timeout=20.0)
                except subprocess.TimeoutExpired:
                    os.killpg(server.pid, signal.SIGKILL)
                    server.wait()

    def test_publisher_rejects_bad_levels_and_stale_timeout(self):
        self.check_rejected('battery_state_pub.py', 'stale_timeout', '-1', 'a number > 0 s')
        self.check_rejected('battery_state_pub.py', 'low_percentage', '20', 'a fraction in [0, 1]')
        code, output = run_node('battery_state_pub.py', '_low_percentage:=0.1', '_critical_percentage:=0.3')
        self.assertNotEqual(code, 0)
        self.assertIn('critical_percentage', output)
        self.assertIn('0.3', output)

    def test_publisher_rejects_bad_rate(self):
        self.check_rejected('battery_state_pub.py', 'rate', '0', 'a number in (0, 1000] Hz')


if __name__ == '__main__':
    rospy.init_node('test_bad_startup')
    rostest.rosrun('battery_simulator', 'bad_startup', TestBadStartup)
