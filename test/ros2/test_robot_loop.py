"""The robot's loop on ROS 2 (Parts 2-3 and 6-7 against the rclpy nodes): the cut-off gate stops forwarding
at Empty and forwards the type it receives, the dock contact from odometry, fake_base integrating cmd_vel
(Twist or TwistStamped) on a sim_clock, sim_clock's bounded tick, patrol_and_dock's phase, bad parameters.
Each node in a namespace of its own; every wait has a bound."""
import math
import time

import pytest
from geometry_msgs.msg import Twist, TwistStamped
from nav_msgs.msg import Odometry
from rosgraph_msgs.msg import Clock
from std_msgs.msg import Bool, String

from battery_simulator.msg import BatterySimState
from ros2_probe import LATCHED, RELIABLE, NodeProcess, Probe


@pytest.fixture(scope='module')
def probe():
    probe = Probe('robot_loop_probe')
    yield probe
    probe.close()


def stopped(*processes):
    """End every one of ``processes`` (all of them, whatever the first says), then check each ended cleanly."""
    statuses = [process.stop() for process in processes]
    for process, status in zip(processes, statuses):
        assert status == 0, '%s did not end cleanly on SIGINT:\n%s' % (process.process.args[0], process.output())
        assert 'Traceback' not in process.output(), process.output()


class Repeater:
    """Publishes a message every 50 ms (wall) from the probe until closed."""

    def __init__(self, probe, msg_type, topic, msg, qos=RELIABLE):
        self.msg = msg
        self.pub = probe.node.create_publisher(msg_type, topic, qos)
        self.timer = probe.node.create_timer(0.05, lambda: self.pub.publish(self.msg))

    def close(self, probe):
        probe.node.destroy_timer(self.timer)
        probe.node.destroy_publisher(self.pub)


def twist(linear=0.0, angular=0.0):
    msg = Twist()
    msg.linear.x, msg.angular.z = linear, angular
    return msg


def test_the_gate_relays_until_empty_then_stops_once_and_drops(probe):
    gate = NodeProcess('battery_cmd_vel_gate', '-r', '__ns:=/gate')
    state_pub = probe.node.create_publisher(BatterySimState, '/gate/battery_simulator/state', LATCHED)
    commands = Repeater(probe, Twist, '/gate/cmd_vel_in', twist(0.4, 0.1))
    try:
        relayed = probe.wait_for('/gate/cmd_vel_out', Twist, lambda m: m.linear.x == 0.4, 20.0)
        assert relayed is not None, 'no command relayed within 20 s:\n' + gate.output()
        state_pub.publish(BatterySimState(charging_state='Empty', cut_off='under-voltage'))
        stop_seen = probe.wait_for('/gate/cmd_vel_out', Twist, lambda m: m.linear.x == 0.0, 5.0)
        assert stop_seen is not None, 'no zero Twist at Empty:\n' + gate.output()
        since = time.monotonic() + 0.3   # what was in flight
        time.sleep(1.0)
        received = [msg for at, msg in probe.follow('/gate/cmd_vel_out', Twist) if at >= since]
        assert not any(msg.linear.x != 0.0 for msg in received), 'a command forwarded at Empty'
        assert gate.wait_for_output('battery empty', 5.0), gate.output()
        state_pub.publish(BatterySimState(charging_state='Charging'))
        assert probe.wait_for('/gate/cmd_vel_out', Twist, lambda m: m.linear.x == 0.4, 5.0,
                              since=time.monotonic()) is not None, 'not relaying again after Empty'
        commands.msg = twist(math.nan, 0.0)
        assert probe.wait_for('/gate/cmd_vel_out', Twist, lambda m: m.linear.x == 0.0, 5.0,
                              since=time.monotonic()) is not None, 'no stop for a NaN command'
        assert gate.wait_for_output('non-finite', 5.0), gate.output()
    finally:
        commands.close(probe)
        stopped(gate)


def test_the_gate_and_the_base_take_twist_stamped(probe):
    gate = NodeProcess('battery_cmd_vel_gate', '-r', '__ns:=/stamped', '-r', 'cmd_vel_in:=nav', '-r',
                       'cmd_vel_out:=cmd_vel')
    base = NodeProcess('fake_base', '-r', '__ns:=/stamped')
    msg = TwistStamped()
    msg.header.frame_id, msg.twist.linear.x = 'base_link', 0.5
    commands = Repeater(probe, TwistStamped, '/stamped/nav', msg)
    try:
        forwarded = probe.wait_for('/stamped/cmd_vel', TwistStamped, lambda m: m.twist.linear.x == 0.5, 20.0)
        assert forwarded is not None and forwarded.header.frame_id == 'base_link', \
            'the gate did not forward TwistStamped as TwistStamped:\n' + gate.output()
        moved = probe.wait_for('/stamped/odom', Odometry, lambda m: m.pose.pose.position.x > 0.2, 20.0)
        assert moved is not None, 'fake_base did not drive on TwistStamped:\n' + base.output()
    finally:
        commands.close(probe)
        stopped(gate, base)


def test_the_dock_contact_reports_contact_from_odometry(probe):
    contact = NodeProcess('battery_dock_contact', '-r', '__ns:=/dock', '-p', 'dock_x:=1.0', '-p', 'dock_y:=2.0')
    odom = Odometry()
    odom.pose.pose.position.x, odom.pose.pose.position.y = 5.0, 5.0
    feed = Repeater(probe, Odometry, '/dock/odom', odom)
    try:
        assert probe.wait_for('/dock/charger_contact', Bool, lambda m: not m.data, 20.0, qos=LATCHED) is not None, \
            'no charger_contact false:\n' + contact.output()
        odom.pose.pose.position.x, odom.pose.pose.position.y = 1.1, 2.1
        assert probe.wait_for('/dock/charger_contact', Bool, lambda m: m.data, 5.0, qos=LATCHED) is not None, \
            'no contact on the dock:\n' + contact.output()
        odom.twist.twist.linear.x = 0.3
        assert probe.wait_for('/dock/charger_contact', Bool, lambda m: not m.data, 5.0, qos=LATCHED,
                              since=time.monotonic()) is not None, 'contact while driving over the dock'
    finally:
        feed.close(probe)
        stopped(contact)


def test_sim_clock_ticks_its_bounded_step_and_fake_base_follows_it(probe):
    clock = NodeProcess('sim_clock', '-p', 'speed:=5.0', '-p', 'tick_hz:=250.0', '-r', '__ns:=/timed')
    base = NodeProcess('fake_base', '-r', '__ns:=/timed', '-p', 'use_sim_time:=true')
    commands = Repeater(probe, Twist, '/timed/cmd_vel', twist(0.3))
    try:
        ticks = []
        assert probe.wait_for('/clock', Clock, lambda m: ticks.append(m.clock.sec + m.clock.nanosec * 1e-9)
                              or len(ticks) > 50, 20.0) is not None, 'no /clock:\n' + clock.output()
        steps = [b - a for a, b in zip(ticks, ticks[1:]) if b > a]
        assert steps and all(abs(step / 0.02 - round(step / 0.02)) < 1e-6
                             for step in steps), steps[:10]
        first = probe.wait_for('/timed/odom', Odometry, lambda m: m.pose.pose.position.x > 1.0, 30.0)
        assert first is not None, 'fake_base on sim time did not move:\n' + base.output()
        t0 = first.header.stamp.sec + first.header.stamp.nanosec * 1e-9
        later = probe.wait_for('/timed/odom', Odometry, lambda m: m.header.stamp.sec > t0 + 20, 30.0)
        assert later is not None
        t1 = later.header.stamp.sec + later.header.stamp.nanosec * 1e-9
        travelled = later.pose.pose.position.x - first.pose.pose.position.x
        assert travelled == pytest.approx(0.3 * (t1 - t0), rel=0.1), \
            'drove %.2f m in %.1f s of ROS time at 0.3 m/s' % (travelled, t1 - t0)
    finally:
        commands.close(probe)
        stopped(base, clock)


@pytest.mark.parametrize('executable, parameter, value', [
    ('fake_base', 'rate', '0.0'), ('battery_dock_contact', 'radius', '-1.0'), ('sim_clock', 'speed', '20000.0'),
    ('patrol_and_dock', 'waypoints', '[1.0, 2.0, 3.0]')])
def test_a_bad_parameter_ends_the_node_with_one_line(executable, parameter, value):
    node = NodeProcess(executable, '-p', '%s:=%s' % (parameter, value), '-r', '__ns:=/bad')
    status = node.wait(20.0)
    node.stop()   # (if it is still running)
    assert status not in (None, 0), '%s ran with %s = %s:\n%s' % (executable, parameter, value, node.output())
    lines = [line for line in node.output().splitlines() if parameter in line]
    assert len(lines) == 1 and 'is invalid: must be' in lines[0], node.output()
    assert 'Traceback' not in node.output(), node.output()


def test_patrol_and_dock_waits_for_the_battery_then_patrols(probe):
    battery = NodeProcess('battery_sim', '-r', '__ns:=/patrol', '-p', 'time_scale:=50.0')
    base = NodeProcess('fake_base', '-r', '__ns:=/patrol', '-p', 'x:=1.0')
    behaviour = NodeProcess('patrol_and_dock', '-r', '__ns:=/patrol')
    try:
        phase = probe.wait_for('/patrol/patrol_and_dock/phase', String, lambda m: m.data == 'PATROL', 40.0,
                               qos=LATCHED)
        assert phase is not None, 'no PATROL phase:\n' + behaviour.output()
        assert behaviour.wait_for_output('phase PATROL at', 5.0), behaviour.output()
        moved = probe.wait_for('/patrol/odom', Odometry, lambda m: m.pose.pose.position.x > 1.3, 30.0)
        assert moved is not None, 'the robot did not patrol:\n' + behaviour.output() + base.output()
    finally:
        stopped(behaviour, base, battery)


def test_sim_clock_holds_ros_time_until_the_named_topics_have_publishers(probe):
    clock = NodeProcess('sim_clock', '-p', 'speed:=10.0', '-p', 'start:=100.0', '-p', 'tick_hz:=100.0',
                        '-p', "wait_for:=['held/ready']", '-r', '__ns:=/held')
    try:
        since = time.monotonic()
        ticks = probe.follow('/clock', Clock)
        assert probe.wait_for('/clock', Clock, lambda m: len([at for at, _ in ticks if at >= since]) >= 10, 20.0,
                              since=since) is not None, clock.output()
        held = {m.clock.sec for at, m in ticks if at >= since}
        assert held == {100}, 'the clock ran before held/ready had a publisher: %s' % sorted(held)
        assert clock.wait_for_output('holding ROS time at 100 s until /held/held/ready', 5.0), clock.output()
        ready = probe.node.create_publisher(Bool, '/held/held/ready', 1)
        try:
            assert probe.wait_for('/clock', Clock, lambda m: m.clock.sec > 101, 20.0) is not None, \
                'the clock did not start once held/ready had a publisher:\n' + clock.output()
        finally:
            probe.node.destroy_publisher(ready)
    finally:
        stopped(clock)
