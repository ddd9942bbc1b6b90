"""docs/consumers.md's recipes, each played the way the consumer's code reads the battery (rclpy in the
test process, against a battery_sim): Nav2's IsBatteryLow / IsBatteryCharging, opennav_docking's
SimpleChargingDock, an Open-RMF EasyFullControl adapter's battery_soc and predict, and what
battery_doctor says of ros2_control's battery_state_broadcaster (0-100) and Gazebo's sign.

Tests marked xfail(strict=True) need a feature another change adds (Part 7): they fail today, and
turn into failures once it lands, so that whoever merges it removes the mark."""
import time

import pytest
import rclpy
from geometry_msgs.msg import TwistStamped
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy, qos_profile_system_default
from sensor_msgs.msg import BatteryState
from std_msgs.msg import Bool
from std_srvs.srv import SetBool

from battery_simulator.srv import Predict, SetState
from ros2_probe import NodeProcess, Probe

NS = '/consumer'
#: opennav_docking's SimpleChargingDock: charging_threshold (A) and the docking server's wait_charge_timeout (s)
CHARGING_THRESHOLD_A = 0.5
WAIT_CHARGE_TIMEOUT_S = 5.0
#: the battery's parameter for Nav2's topic name (Part 7; set by the change that adds it)
NAN = float('nan')


@pytest.fixture(scope='module')
def probe():
    probe = Probe('consumer_test_probe')
    yield probe
    probe.close()


@pytest.fixture(scope='module')
def sim(probe):
    process = NodeProcess('battery_sim', '-r', '__ns:=' + NS, '-p', 'rate:=5.0', '-p', 'update_rate:=20.0')
    assert probe.wait_for(NS + '/battery_status', BatteryState, timeout_s=20.0) is not None, process.output()
    yield process
    assert process.stop() == 0, process.output()


class Reader:
    """A consumer's subscription in a node of its own (namespace, remaps and QoS as the consumer has
    them) that keeps the last value its rule computes."""

    def __init__(self, probe, name, topic, rule, qos, namespace=NS, remaps=()):
        cli_args = ['--ros-args'] + [arg for remap in remaps for arg in ('-r', remap)] if remaps else None
        self.node = Node(name, namespace=namespace, cli_args=cli_args)
        self.values = []
        self.node.create_subscription(BatteryState, topic, lambda msg: self.values.append(rule(msg)), qos)
        self._probe = probe
        probe._executor.add_node(self.node)

    def wait_until(self, predicate, timeout_s):
        deadline = time.monotonic() + timeout_s
        start = len(self.values)
        while time.monotonic() < deadline:
            if any(predicate(v) for v in self.values[start:]):
                return True
            time.sleep(0.02)
        return False

    def close(self):
        self._probe._executor.remove_node(self.node)
        self.node.destroy_node()


def set_state(probe, percentage):
    answer = probe.call(SetState, NS + '/battery_simulator/set_state', SetState.Request(
        percentage=float(percentage), temperature_c=NAN, state_of_health=NAN))
    assert answer.success, answer.message


def set_charging(probe, on):
    assert probe.call(SetBool, NS + '/battery_simulator/set_charging', SetBool.Request(data=on)).success


def test_nav2_is_battery_low_and_is_battery_charging(sim, probe):
    # nav2_behavior_tree IsBatteryLow: percentage <= min_battery (0-1) on battery_topic, SystemDefaultsQoS
    low = Reader(probe, 'is_battery_low', NS + '/battery_status', lambda msg: msg.percentage <= 0.2,
                 qos_profile_system_default)
    # IsBatteryCharging: power_supply_status == CHARGING
    charging = Reader(probe, 'is_battery_charging', NS + '/battery_status',
                      lambda msg: msg.power_supply_status == BatteryState.POWER_SUPPLY_STATUS_CHARGING,
                      qos_profile_system_default)
    try:
        set_charging(probe, False)
        set_state(probe, 15.0)
        assert low.wait_until(lambda is_low: is_low, 5.0), 'IsBatteryLow(min_battery=0.2) not true at 15 %'
        set_state(probe, 80.0)
        assert low.wait_until(lambda is_low: not is_low, 5.0), 'IsBatteryLow still true at 80 %'
        set_charging(probe, True)
        assert charging.wait_until(lambda c: c, 5.0), 'IsBatteryCharging not true after set_charging'
        set_charging(probe, False)
        assert charging.wait_until(lambda c: not c, 5.0), 'IsBatteryCharging still true after discharging'
    finally:
        low.close()
        charging.close()


def test_simple_charging_dock_with_the_documented_remap(sim, probe):
    # SimpleChargingDock: subscribes "battery_state" (relative to the docking server's namespace) and
    # calls it charging when current > charging_threshold; the docking server waits wait_charge_timeout
    dock = Reader(probe, 'docking_server', 'battery_state', lambda msg: msg.current > CHARGING_THRESHOLD_A,
                  QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE), remaps=['battery_state:=battery_status'])
    try:
        set_charging(probe, False)
        set_state(probe, 50.0)
        set_charging(probe, True)
        assert dock.wait_until(lambda c: c, WAIT_CHARGE_TIMEOUT_S), \
            'SimpleChargingDock saw no current above 0.5 A within 5 s of a charge at 50 %'
        set_charging(probe, False)
        assert dock.wait_until(lambda c: not c, WAIT_CHARGE_TIMEOUT_S), 'still charging 5 s after it ended'
    finally:
        dock.close()


def test_simple_charging_dock_on_battery_state_without_a_remap(probe):
    ns = '/dock_no_remap'
    process = NodeProcess('battery_sim', '-r', '__ns:=' + ns, '-p', 'rate:=5.0')   # battery_state by default
    try:
        assert probe.wait_for(ns + '/battery_state', BatteryState, timeout_s=15.0,
                              qos=QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE)) is not None, \
            'no %s/battery_state from battery_sim:\n%s' % (ns, process.output())
    finally:
        process.stop()


def test_simple_charging_dock_with_a_full_pack(sim, probe):
    dock = Reader(probe, 'full_pack_docking_server', NS + '/battery_status',
                  lambda msg: msg.current > CHARGING_THRESHOLD_A, QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE))
    contact = probe.node.create_publisher(Bool, NS + '/charger_contact', 10)
    try:
        set_charging(probe, False)
        set_state(probe, 100.0)
        contact.publish(Bool(data=True))
        assert dock.wait_until(lambda c: c, WAIT_CHARGE_TIMEOUT_S), \
            'a full pack on the dock showed no current above 0.5 A within 5 s'
        contact.publish(Bool(data=False))
        assert dock.wait_until(lambda c: not c, WAIT_CHARGE_TIMEOUT_S), 'still above 0.5 A 5 s after leaving'
    finally:
        contact.publish(Bool(data=False))
        probe.node.destroy_publisher(contact)
        dock.close()


def test_nav2_kilted_twist_stamped_cmd_vel_drains(sim, probe):
    standing = Reader(probe, 'drain_reader', NS + '/battery_status', lambda msg: msg.current,
                      QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE))
    cmd_vel = probe.node.create_publisher(TwistStamped, NS + '/cmd_vel', 10)
    try:
        set_charging(probe, False)
        set_state(probe, 80.0)
        deadline = time.monotonic() + 10.0   # discovery, then the type looked up within 2 s
        drained = False
        while time.monotonic() < deadline and not drained:
            msg = TwistStamped()
            msg.twist.linear.x = 0.5
            cmd_vel.publish(msg)
            drained = any(current < -2.0 for current in standing.values[-3:])
            time.sleep(0.1)
        assert drained, 'TwistStamped at 0.5 m/s: the current stayed at %s A' % standing.values[-3:]
    finally:
        probe.node.destroy_publisher(cmd_vel)
        standing.close()


def test_open_rmf_battery_soc_and_predict(sim, probe):
    # an EasyFullControl adapter: RobotState(map, position, battery_soc) with battery_soc in 0-1,
    # as free_fleet's Nav2 adapter takes it: battery_soc = BatteryState.percentage
    soc = Reader(probe, 'rmf_adapter', NS + '/battery_status', lambda msg: msg.percentage,
                 QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE))
    try:
        set_charging(probe, False)
        set_state(probe, 42.0)
        assert soc.wait_until(lambda value: abs(value - 0.42) < 0.01, 5.0), \
            'battery_soc not 0.42 at 42 %%: %s' % soc.values[-3:]
        assert all(0.0 <= value <= 1.0 for value in soc.values), 'battery_soc outside 0-1'
        # task planning: what a 10-minute task at 20 W leaves (predict answers in percent: / 100 for RMF)
        answer = probe.call(Predict, NS + '/battery_simulator/predict',
                            Predict.Request(duration_s=[600.0], power_w=[20.0]))
        assert answer.success and answer.feasible, answer
        assert 0.0 < answer.end_percentage / 100.0 < 0.42, 'predicted battery_soc %s' % answer.end_percentage
    finally:
        soc.close()


def test_doctor_names_a_broadcaster_percentage_and_a_gazebo_sign(sim, probe):
    """battery_state_broadcaster without a battery_percentage interface computes (V - min) * 100 / (max - min);
    Gazebo's LinearBatteryPlugin without invert_current_sign publishes the load current positive."""
    node = Node('battery_state_broadcaster', namespace='/ctrl')
    probe._executor.add_node(node)
    broadcaster = node.create_publisher(BatteryState, '~/battery_state', qos_profile_system_default)
    gazebo = node.create_publisher(BatteryState, '/gz/battery_state', qos_profile_system_default)

    def relay(msg):
        out = BatteryState(voltage=msg.voltage, current=msg.current, power_supply_status=msg.power_supply_status)
        out.percentage = (msg.voltage - 9.0) * 100.0 / (12.6 - 9.0)
        broadcaster.publish(out)
        gz = BatteryState(voltage=msg.voltage, current=-msg.current, percentage=msg.percentage,
                          power_supply_status=BatteryState.POWER_SUPPLY_STATUS_DISCHARGING)
        gazebo.publish(gz)
    node.create_subscription(BatteryState, NS + '/battery_status', relay, 10)
    try:
        set_charging(probe, False)
        set_state(probe, 80.0)
        doctor = NodeProcess('battery_doctor', args=('--sample', '3'))
        code = doctor.wait(30.0)
        output = doctor.output()
        assert code == 1, 'exit %s:\n%s' % (code, output)
        lines = [line for line in output.splitlines() if line.startswith('problem:')]
        assert [line for line in lines if line.startswith('problem: /ctrl/battery_state_broadcaster/battery_state:')
                and 'above 1' in line], output
        assert [line for line in lines if line.startswith('problem: /gz/battery_state:')
                and 'positive while power_supply_status is DISCHARGING' in line], output
    finally:
        probe._executor.remove_node(node)
        node.destroy_node()
