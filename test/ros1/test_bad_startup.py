#!/usr/bin/python3
"""rostest: bad start-up values stop a node with one fatal line naming the
parameter, the value and what is allowed, and a non-zero exit.

Every bad start-up is independent, so they all run at once (four at a time)
before the checks; each check then reads its own node's output."""
import atexit
import concurrent.futures
import itertools
import os
import shutil
import signal
import socket
import subprocess
import tempfile
import unittest

import rospy
import rostest
from rosgraph_msgs.msg import Log

from battery_simulator.core.node_settings import EXIT_STARTUP_ERROR
from rostest_helpers import Recorder, node_command, stop_process, wait_for

STARTUP_TIMEOUT_S = 60.0
RUN_NUMBERS = itertools.count()
CONFIG_DIR = tempfile.mkdtemp(prefix='battery_simulator_bad_startup_')
atexit.register(shutil.rmtree, CONFIG_DIR, True)   # the configs and state files this test wrote


def config_file(name, content):
    path = os.path.join(CONFIG_DIR, name + '.yaml')
    with open(path, 'wb') as stream:
        stream.write(content)
    return path


SERVER, PUBLISHER, FLEET, CLOCK = 'battery_sim_server.py', 'battery_state_pub.py', 'battery_fleet.py', 'sim_clock.py'
BAD_VALUE_YAML = config_file('bad_value', b'preset: lg_hg2_3s1p\nload_current_a: -2\n')
USER_FILE_BYTES = b'# my robot\npreset: lg_hg2_3s1p\nload_current_a: 2.0\n'
USER_FILE = config_file('my_robot_config', USER_FILE_BYTES)   # a typo: state_file:= the robot's config
#: case -> (script, [param:=value ...]); each runs once, all at once
CASES = {
    'time_scale': (SERVER, ['_time_scale:=-3']),
    'update_rate': (SERVER, ['_update_rate:=fast']),
    'initial_percentage': (SERVER, ['_initial_percentage:=120']),
    'charging': (SERVER, ['_charging:=maybe']),
    'missing_config': (SERVER, ['_config:=/nonexistent/battery.yaml']),
    'bad_yaml_value': (SERVER, ['_config:=' + BAD_VALUE_YAML]),
    'empty_config': (SERVER, ['_config:=' + config_file('empty', b'')]),
    'key_not_text': (SERVER, ['_config:=' + config_file('key', b'1: 2\n')]),
    'not_utf8': (SERVER, ['_config:=' + config_file('utf8', b'location: "\xff"\n')]),
    'absurd_cells': (SERVER, ['_config:=' + config_file('cells', b'cells_series: 1000000\n')]),
    'absurd_load': (SERVER, ['_config:=' + config_file('load', b'load_current_a: 1000\n')]),
    'rate': (PUBLISHER, ['_rate:=0']),
    'stale_timeout': (PUBLISHER, ['_stale_timeout:=-1']),
    'low_percentage': (PUBLISHER, ['_low_percentage:=20']),
    'critical_above_low': (PUBLISHER, ['_low_percentage:=0.1', '_critical_percentage:=0.3']),
    'fleet_duplicate': (FLEET, ['_robots:=[{name: a}, {name: b}, {name: a}]']),
    'fleet_name': (FLEET, ['_robots:=[{name: "robot-1"}]']),
    'fleet_level': (FLEET, ['_robots:=[{name: a}, {name: b, initial_percentage: 150}]']),
    'fleet_config': (FLEET, ['_robots:=[{name: a, config: /nonexistent/b.yaml}]']),
    'fleet_count': (FLEET, ['_robots:=0']),
    'fleet_time_scale': (FLEET, ['_robots:=2', '_time_scale:=-3']),
    # fleet.launch's n and hosts, as the launch passes them to each host
    'launch_n': (FLEET, ['_fleet_size:=abc', '_hosts:=1', '_host_index:=0']),
    'launch_hosts_zero': (FLEET, ['_fleet_size:=3', '_hosts:=0', '_host_index:=0']),
    'launch_hosts_negative': (FLEET, ['_fleet_size:=3', '_hosts:=-2', '_host_index:=0']),
    'launch_hosts_above_n': (FLEET, ['_fleet_size:=2', '_hosts:=5', '_host_index:=0']),
    'state_file_not_a_state_file': (SERVER, ['_state_file:=' + USER_FILE]),
    'state_file_unwritable': (SERVER, ['_state_file:=/nonexistent_dir/x.json']),
    'state_file_a_directory': (SERVER, ['_state_file:=' + CONFIG_DIR]),
    'clock_start': (CLOCK, ['_start:=5e9']),
    'clock_start_int': (CLOCK, ['_start:=5000000000']),
    'clock_runs_out': (CLOCK, ['_start:=4294967294.9', '_speed:=10']),
}


def run_node(script, params):
    """Run a node of the package on this test's master until it exits; (exit code, output)."""
    name = 'bad_%s_%d' % (script.split('.')[0], next(RUN_NUMBERS))  # private params do not leak
    command = node_command(script) + ['__name:=' + name] + list(params)
    result = subprocess.run(command, capture_output=True, text=True, timeout=STARTUP_TIMEOUT_S)
    return result.returncode, result.stdout + result.stderr


class TestBadStartup(unittest.TestCase):

    @classmethod
    def setUpClass(cls):
        cls.log = Recorder('/rosout', Log)
        with concurrent.futures.ThreadPoolExecutor(max_workers=4) as pool:
            futures = {case: pool.submit(run_node, *CASES[case]) for case in CASES}
            cls.results = {case: future.result() for case, future in futures.items()}

    def check_rejected(self, case, param, value, allowed):
        code, output = self.results[case]
        self.assertEqual(code, EXIT_STARTUP_ERROR, '%s exited %s, not %d:\n%s' % (case, code, EXIT_STARTUP_ERROR, output))
        fatal = [line for line in output.splitlines() if 'FATAL' in line]
        self.assertEqual(len(fatal), 1, 'one fatal line expected:\n%s' % output)
        self.assertIn(param, fatal[0])
        self.assertIn(value, fatal[0], 'the fatal line names the value')
        self.assertIn(allowed, fatal[0])
        self.assertNotIn('Traceback', output)

    def test_server_rejects_bad_time_scale(self):
        self.check_rejected('time_scale', 'time_scale', '-3', 'a number in (0, 10000]')

    def test_server_rejects_bad_update_rate(self):
        self.check_rejected('update_rate', 'update_rate', 'fast', 'a number in (0, 1000] Hz')

    def test_server_rejects_bad_initial_percentage(self):
        self.check_rejected('initial_percentage', 'initial_percentage', '120', 'a number in [0, 100]')

    def test_server_rejects_bad_charging(self):
        self.check_rejected('charging', 'charging', 'maybe', 'true or false')

    def test_server_rejects_missing_config_file(self):
        self.check_rejected('missing_config', 'config', '/nonexistent/battery.yaml', 'cannot read')

    def test_server_rejects_bad_yaml_value_naming_file_and_key(self):
        self.check_rejected('bad_yaml_value', 'config', BAD_VALUE_YAML, 'load_current_a')
        self.assertIn('-2', self.results['bad_yaml_value'][1])

    def test_server_rejects_unusable_config_files_with_one_line(self):
        for case, allowed in (('empty_config', 'is empty'), ('key_not_text', 'must be text'),
                              ('not_utf8', 'not UTF-8'), ('absurd_cells', 'cells_series'),
                              ('absurd_load', 'load_current_a')):
            with self.subTest(case=case):
                self.check_rejected(case, 'config', CASES[case][1][0].split(':=')[1], allowed)

    def test_a_state_file_that_is_not_one_or_cannot_be_written_stops_the_server(self):
        self.check_rejected('state_file_not_a_state_file', 'state_file', USER_FILE, 'never written over')
        with open(USER_FILE, 'rb') as stream:
            self.assertEqual(stream.read(), USER_FILE_BYTES, "the user's file was written over")
        self.check_rejected('state_file_unwritable', 'state_file', '/nonexistent_dir/x.json', 'cannot be written')
        self.check_rejected('state_file_a_directory', 'state_file', CONFIG_DIR, 'it is a directory')

    def test_publisher_rejects_bad_rate(self):
        self.check_rejected('rate', 'rate', '0', 'a number in (0, 1000] Hz')

    def test_publisher_rejects_bad_levels_and_stale_timeout(self):
        self.check_rejected('stale_timeout', 'stale_timeout', '-1', 'a number > 0 s')
        self.check_rejected('low_percentage', 'low_percentage', '20', 'a fraction in [0, 1]')
        self.check_rejected('critical_above_low', 'critical_percentage', '0.3', 'at most ~low_percentage')

    def test_a_fleet_host_names_the_bad_robot_and_key(self):
        self.check_rejected('fleet_duplicate', 'robot a', 'name', 'another robot has it already')
        self.check_rejected('fleet_name', 'name', "'robot-1'", 'must start with a letter')
        self.check_rejected('fleet_level', 'robot b', '150', 'initial_percentage')
        self.check_rejected('fleet_config', 'robot a', '/nonexistent/b.yaml', 'cannot read')
        self.check_rejected('fleet_count', 'robots', '0', 'a count in [1, 10000]')
        self.check_rejected('fleet_time_scale', 'time_scale', '-3', 'a number in (0, 10000]')

    def test_fleet_launch_arguments_are_named(self):
        self.check_rejected('launch_n', 'argument n', "'abc'", 'a whole number of robots')
        self.check_rejected('launch_hosts_zero', 'argument hosts', '0', 'in [1, n = 3]')
        self.check_rejected('launch_hosts_negative', 'argument hosts', '-2', 'in [1, n = 3]')
        self.check_rejected('launch_hosts_above_n', 'argument hosts', '5', 'in [1, n = 2]')

    def test_the_clock_refuses_a_start_no_ros_time_holds_and_stops_at_the_end(self):
        self.check_rejected('clock_start', 'start', '5000000000', '4294967295')
        self.check_rejected('clock_start_int', 'parameter', '5000000000', 'as a float')
        self.check_rejected('clock_runs_out', 'sim_clock', '4294967295', 'the largest a ROS time holds')

    def test_numbers_that_roslaunch_passes_as_text_are_accepted(self):
        name = 'text_numbers_%d' % next(RUN_NUMBERS)
        rospy.set_param('/%s/time_scale' % name, '1e3')          # as roslaunch passes time_scale:=1e3
        rospy.set_param('/%s/initial_percentage' % name, ' 50 ')
        server = subprocess.Popen(node_command(SERVER) + ['__name:=' + name],
                                  stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
        try:
            wait_for(lambda: any(m.name == '/' + name and 'ready' in m.msg for m in self.log.since(0))
                     or server.poll() is not None, STARTUP_TIMEOUT_S, 'the server ready')
            self.assertIsNone(server.poll(), 'the server refused numeric text (exit %s)' % server.poll())
        finally:
            stop_process(server)

    def start_server(self, namespace, *params):
        """A server in ``namespace`` (another robot's), waited for until ready; the process."""
        server = subprocess.Popen(node_command(SERVER) + ['__ns:=' + namespace] + list(params),
                                  stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
        self.addCleanup(stop_process, server)
        wait_for(lambda: any(m.name == namespace + '/BatterySimServer' and 'ready' in m.msg
                             for m in self.log.since(0)) or server.poll() is not None, STARTUP_TIMEOUT_S,
                 'the server in %s ready' % namespace)
        self.assertIsNone(server.poll(), 'the server in %s ended (exit %s)' % (namespace, server.poll()))
        return server

    def test_a_state_file_another_battery_holds_is_refused_naming_it(self):
        """Issue 40 item 7: two batteries given one state_file: the second stops at start with one line naming
        the file and the battery that holds it (before: it resumed the first one's state and both wrote it);
        a holder killed with SIGKILL does not block its restart."""
        path = os.path.join(CONFIG_DIR, 'shared_state.json')
        holder = self.start_server('/s1', '_state_file:=' + path)
        code, output = run_node(SERVER, ['__ns:=/s2', '_state_file:=' + path, '_initial_percentage:=30'])
        self.assertNotEqual(code, 0, output)   # as every refused start of the ROS 1 server
        fatal = [line for line in output.splitlines() if 'FATAL' in line]
        self.assertEqual(len(fatal), 1, 'one fatal line expected:\n%s' % output)
        self.assertIn(path, fatal[0])
        self.assertIn('/s1/BatterySimServer', fatal[0], 'the line names the battery that holds the file')
        os.killpg(holder.pid, signal.SIGKILL)
        holder.wait()
        self.start_server('/s1', '_state_file:=' + path)   # the respawn takes the file over

    def test_a_bad_value_stops_a_respawning_launch_with_one_line(self):
        # sim.launch respawns the server: a bad value used to print the same FATAL line every 2 s for ever
        port = free_port()
        environment = dict(os.environ, ROS_MASTER_URI='http://127.0.0.1:%d' % port)
        launch = subprocess.Popen(['roslaunch', '-p', str(port), 'battery_simulator',
                                   'sim.launch', 'time_scale:=-3'], env=environment, stdout=subprocess.PIPE,
                                  stderr=subprocess.STDOUT, text=True, start_new_session=True)
        try:
            output, _ = launch.communicate(timeout=STARTUP_TIMEOUT_S)
        except subprocess.TimeoutExpired:
            stop_process(launch)
            self.fail('the launch went on (respawning) instead of stopping')
        fatal = [line for line in output.splitlines() if 'FATAL' in line]
        self.assertEqual(len(fatal), 1, 'one fatal line expected:\n%s' % output)
        self.assertIn('time_scale = -3', fatal[0])
        self.assertIn('stopping the launch', fatal[0])


def free_port():
    with socket.socket() as probe:
        probe.bind(('127.0.0.1', 0))
        return probe.getsockname()[1]


if __name__ == '__main__':
    rospy.init_node('test_bad_startup')
    rostest.rosrun('battery_simulator', 'bad_startup', TestBadStartup)
