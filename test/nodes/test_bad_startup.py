#!/usr/bin/python3
"""rostest: bad start-up values stop a node with one fatal line naming the
parameter, the value and what is allowed, and a non-zero exit."""
import itertools
import subprocess
import unittest

import rospy
import rostest

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

    def test_publisher_rejects_bad_rate(self):
        self.check_rejected('battery_state_pub.py', 'rate', '0', 'a number in (0, 1000] Hz')


if __name__ == '__main__':
    rospy.init_node('test_bad_startup')
    rostest.rosrun('battery_simulator', 'bad_startup', TestBadStartup)
