#!/usr/bin/python3
"""rostest: fleet hosts (test/ros1/fleet.test): fleet.launch n:=6 hosts:=2 splits the robots
between two processes, staggered; the list form of ~robots; ~states; a SIGKILLed host
is respawned and every robot resumes within 1 %; a host of 100 robots starts under a
soft limit of 1024 open files."""
import os
import resource
import signal
import subprocess
import unittest
import xmlrpc.client

import rosgraph
import rospy
import rostest
from rosgraph_msgs.msg import Log
from sensor_msgs.msg import BatteryState

from battery_simulator.msg import BatteryFleetState
from battery_simulator.srv import InjectFault, SetLoad, SetState
from rostest_helpers import Recorder, SetStateProxy, node_command, stop_process, wait_for

ROBOTS = ['robot%d' % k for k in range(6)]
RATE_HZ = 5.0   # fleet.launch rate in test/ros1/fleet.test


def node_pid(node):
    uri = rosgraph.Master('/test_fleet').lookupNode(node)
    return xmlrpc.client.ServerProxy(uri).getPid('/test_fleet')[2]


def process_start_s(pid):
    """When process ``pid`` started, epoch s (/proc: clock ticks since boot)."""
    with open('/proc/%d/stat' % pid) as stream:
        ticks = int(stream.read().rsplit(')', 1)[1].split()[19])
    with open('/proc/stat') as stream:
        boot_s = next(int(line.split()[1]) for line in stream if line.startswith('btime'))
    return boot_s + ticks / os.sysconf('SC_CLK_TCK')


class TestFleet(unittest.TestCase):

    @classmethod
    def setUpClass(cls):
        rospy.init_node('test_fleet')
        cls.status = {name: Recorder('/%s/battery_status' % name) for name in ROBOTS + ['alpha', 'beta']}
        cls.log = Recorder('/rosout', Log)
        wait_for(lambda: all(r.count() > 0 for r in cls.status.values()), 60.0, 'battery_status of every robot')

    def test_1_two_hosts_split_six_robots_with_staggered_levels(self):
        # the first level heard, less what the battery drained between its host's start and that message: at time
        # x50 a point of charge is 1.7 s, and on a busy machine this test's subscriptions come seconds late (a
        # fresh-clone run with two CPU hogs heard robot2 first at 88.98 %, not 90 +- 1)
        wait_for(lambda: all(self.status[n].count() >= 2 * RATE_HZ for n in ROBOTS), 10.0, 'two seconds of each')
        for k, (name, expected) in enumerate(zip(ROBOTS, (1.00, 0.95, 0.90, 0.85, 0.80, 0.75))):
            heard = self.status[name].since(0)
            first, last = heard[0], heard[-1]
            drain_per_s = max(0.0, (first.percentage - last.percentage)
                              / (last.header.stamp - first.header.stamp).to_sec())
            started_s = process_start_s(node_pid('/battery_fleet' if k < 3 else '/battery_fleet_1'))
            drained = drain_per_s * max(0.0, first.header.stamp.to_sec() - started_s)
            self.assertTrue(expected - 0.01 - drained <= first.percentage <= expected + 0.01,
                            '%s: first heard %.4f at %.1f s after its host started (drained %.4f since), expected '
                            'to start at %.2f' % (name, first.percentage, first.header.stamp.to_sec() - started_s,
                                                 drained, expected))
        self.assertFalse(rospy.has_param('/robot6/MyRobot/BatteryStatus'), 'exactly n robots')
        serials = [self.status[name].latest().serial_number for name in ROBOTS]
        self.assertEqual(len(set(serials)), len(ROBOTS), 'each robot its own serial number: %s' % serials)
        self.assertEqual(node_pid('/battery_fleet'), node_pid('/battery_fleet'))
        self.assertNotEqual(node_pid('/battery_fleet'), node_pid('/battery_fleet_1'), 'two processes')
        # every host publishes its robots on the one topic: one subscription gets the whole fleet
        states = Recorder('/battery_fleet/states', BatteryFleetState)
        wanted = set(ROBOTS + ['alpha', 'beta'])
        wait_for(lambda: {n for m in states.since(0) for n in m.names} >= wanted, 10.0,
                 'every robot of the three hosts on /battery_fleet/states')
        for msg in states.since(0):
            self.assertIn(list(msg.names), [ROBOTS[:3], ROBOTS[3:], ['alpha', 'beta']], 'one host a message')
            self.assertEqual(len(msg.states), len(msg.names))

    def test_1b_every_robot_publishes_at_the_rate(self):
        marks = {name: self.status[name].count() for name in ROBOTS}
        wait_for(lambda: all(self.status[n].count() >= marks[n] + 21 for n in ROBOTS), 10.0, '20 periods each')
        # by the stamps the host gives them as it publishes: their arrival here (a CI run beside two CPU hogs: the
        # first of 21 delayed, 5.96 Hz measured) adds this test process's own delays
        for name in ROBOTS:
            sent = [msg.header.stamp.to_sec() for msg in self.status[name].since(marks[name])]
            measured_hz = (len(sent) - 1) / (sent[-1] - sent[0])
            self.assertAlmostEqual(measured_hz, RATE_HZ, delta=0.1 * RATE_HZ, msg=name)

    def test_2_the_list_form_sets_each_robot_and_the_rest_comes_from_the_host(self):
        alpha, beta = self.status['alpha'].latest(), self.status['beta'].latest()
        self.assertEqual(alpha.power_supply_status, BatteryState.POWER_SUPPLY_STATUS_CHARGING)
        self.assertAlmostEqual(self.status['alpha'].since(0)[0].percentage, 0.42, delta=0.01)
        self.assertEqual(len(alpha.cell_voltage), 4, 'its own config (Kobuki 4S2P)')
        self.assertEqual(beta.power_supply_status, BatteryState.POWER_SUPPLY_STATUS_DISCHARGING)
        self.assertAlmostEqual(self.status['beta'].since(0)[0].percentage, 0.70, delta=0.01)
        self.assertEqual(len(beta.cell_voltage), 3, "the host's config")

    def test_2b_one_robots_bad_mode_fault_or_trip_never_touches_another(self):
        inject = rospy.ServiceProxy('/robot1/battery_simulator/inject_fault', InjectFault)
        set_load = rospy.ServiceProxy('/robot2/battery_simulator/set_load', SetLoad)
        rospy.set_param('/robot0/MyRobot/BatteryStatus', 'junk')
        self.assertTrue(inject('overheat', True).success)
        self.assertTrue(set_load('winch', 240.0).success)   # over the 3S1P pack's 20 A: the protection trips
        try:
            seen = self.status['robot1'].count()
            self.status['robot1'].wait_new(seen, lambda m: m.power_supply_health ==
                                           BatteryState.POWER_SUPPLY_HEALTH_OVERHEAT, 5.0, 'robot1 overheating')
            seen = {name: self.status[name].count() for name in ROBOTS}
            wait_for(lambda: all(self.status[n].count() >= seen[n] + 3 for n in ROBOTS), 10.0, 'three more each')
            for name in ('robot0', 'robot3', 'robot4', 'robot5'):
                for msg in self.status[name].since(seen[name]):
                    self.assertEqual(msg.power_supply_health, BatteryState.POWER_SUPPLY_HEALTH_GOOD, name)
                    self.assertEqual(msg.power_supply_status, BatteryState.POWER_SUPPLY_STATUS_DISCHARGING, name)
            wait_for(lambda: any(m.name == '/battery_fleet' and 'robot0: ' in m.msg and 'junk' in m.msg
                                 for m in self.log.since(0)), 10.0, "robot0's bad mode logged under its name")
        finally:
            rospy.set_param('/robot0/MyRobot/BatteryStatus', 0)
            inject('overheat', False)
            set_load('winch', 0.0)

    def test_3_a_killed_host_is_respawned_and_every_robot_resumes(self):
        hosted = ROBOTS[3:]
        wait_for(lambda: all(self.status[n].latest().percentage < self.status[n].since(0)[0].percentage - 0.02
                             for n in hosted), 30.0, 'every robot of the host drained 2 %')
        pid = node_pid('/battery_fleet_1')
        os.kill(pid, signal.SIGKILL)
        last = {name: self.status[name].latest().percentage for name in hosted}
        seen = {name: self.status[name].count() for name in hosted}
        logged = self.log.count()
        wait_for(lambda: sum('resumed' in m.msg for m in self.log.since(logged) if m.name == '/battery_fleet_1') == 3,
                 30.0, 'three robots resumed')
        self.assertNotEqual(node_pid('/battery_fleet_1'), pid, 'a new process')
        for name in hosted:
            resumed = self.status[name].wait_new(seen[name], lambda m: True, 10.0, name + ' again')
            self.assertLess(abs(resumed.percentage - last[name]), 0.01,
                            '%s resumed at %.2f %% after %.2f %%' % (name, 100 * resumed.percentage, 100 * last[name]))

    def test_5_a_host_given_a_robot_another_host_serves_refuses_it(self):
        name = 'intruding_host'
        rospy.set_param('/%s/robots' % name, [{'name': 'robot1'}, {'name': 'robot2'}])
        intruder = subprocess.run(node_command('battery_fleet.py') + ['__name:=' + name], capture_output=True,
                                  text=True, timeout=60)
        output = intruder.stdout + intruder.stderr
        self.assertNotEqual(intruder.returncode, 0, 'the intruder ran:\n' + output)
        fatal = [line for line in output.splitlines() if 'FATAL' in line]
        self.assertEqual(len(fatal), 1, output)
        self.assertIn('robot1 is already served by /battery_fleet', fatal[0])
        self.assertNotIn('Traceback', output)
        before = self.status['robot1'].count()
        reply = SetStateProxy('/robot1/battery_simulator/set_state')(
            percentage=float('nan'), temperature_c=float('nan'), state_of_health=float('nan'))
        self.assertTrue(reply.success, 'robot1 keeps its services after the intruder ended')
        wait_for(lambda: self.status['robot1'].count() > before + 2, 10.0, 'robot1 battery_status flowing')

    def test_4_a_host_of_100_starts_under_a_soft_limit_of_1024_open_files(self):
        name = 'hundred'
        rospy.set_param('/%s/robots' % name, 100)
        rospy.set_param('/%s/prefix' % name, 'h')

        def soft_limit_1024():
            resource.setrlimit(resource.RLIMIT_NOFILE, (1024, resource.getrlimit(resource.RLIMIT_NOFILE)[1]))
        host = subprocess.Popen(node_command('battery_fleet.py') + ['__name:=' + name], preexec_fn=soft_limit_1024,
                                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
        try:
            states = Recorder('/battery_fleet/states', BatteryFleetState)

            def hundred():
                return [m for m in states.since(0) if len(m.names) == 100 and m.names[0] == 'h0']
            wait_for(lambda: hundred() or host.poll() is not None, 60.0, 'all 100 robots on battery_fleet/states')
            self.assertIsNone(host.poll(), 'the host died (exit %s)' % host.poll())
            self.assertEqual(len(hundred()[0].states), 100)
            raised = [m for m in self.log.since(0) if m.name == '/' + name and 'open files' in m.msg]
            self.assertEqual(len(raised), 1, 'one line about the raised limit')
        finally:
            stop_process(host)


if __name__ == '__main__':
    rostest.rosrun('battery_simulator', 'fleet', TestFleet)
