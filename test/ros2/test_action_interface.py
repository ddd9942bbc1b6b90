"""The battery_simulator action, the charging parameter and battery_status against battery_sim (ROS 2 twin of
test/ros1/action_interface.test), driven from pytest: no ros2cli or launch wheels exist. One battery_sim in /sim
(conftest.py's sim); every wait has a bound; every UDP socket of the processes under test is on 127.0.0.1."""
import os

from action_msgs.msg import GoalStatus
from sensor_msgs.msg import BatteryState

from battery_simulator.action import BatterySim
from ros2_probe import CHARGING, DISCHARGING, FULL, set_state, status_after, udp_sockets


def test_every_udp_socket_is_on_loopback(sim, probe):
    sockets = udp_sockets([sim.pid, os.getpid()])
    assert sockets, 'no UDP socket found for the processes under test (ss -uanp)'
    outside = [(pid, address) for pid, address in sockets if not address.startswith('127.0.0.1:')]
    assert not outside, 'UDP sockets not on 127.0.0.1: %s' % outside


def test_battery_status_fields(sim, probe):
    msg = status_after(probe, '/sim', lambda m: True)
    assert msg is not None, 'no battery_status'
    assert msg.voltage > 0 and 0.0 <= msg.percentage <= 1.0, (msg.voltage, msg.percentage)
    assert msg.header.frame_id == 'battery' and msg.header.stamp.sec > 0
    assert len(msg.cell_voltage) == 3 and len(msg.cell_temperature) == 3, 'three series cells (lg_hg2_3s1p)'
    assert msg.capacity > 0 and msg.design_capacity > 0 and msg.serial_number and msg.present
    assert msg.power_supply_technology == BatteryState.POWER_SUPPLY_TECHNOLOGY_LION


def test_charge_goal_ends_full_with_feedback(sim, probe):
    assert set_state(probe, '/sim', 99.0).success
    feedback = []
    client = probe.action_client(BatterySim, '/sim/battery_simulator')
    handle = probe.send_goal(client, BatterySim.Goal(charge_state=True),
                             feedback=lambda fb: feedback.append(fb.feedback.battery_percentage))
    result = probe.result(handle, 60.0)
    assert result.status == GoalStatus.STATUS_SUCCEEDED, result
    assert result.result.battery_status == 'Full'
    assert feedback and all(0.0 <= p <= 100.0 for p in feedback), feedback
    assert status_after(probe, '/sim', lambda m: m.power_supply_status == FULL) is not None, 'FULL not published'


def test_discharge_goal_ends_empty(sim, probe):
    assert set_state(probe, '/sim', 0.4).success
    client = probe.action_client(BatterySim, '/sim/battery_simulator')
    result = probe.result(probe.send_goal(client, BatterySim.Goal(charge_state=False)), 60.0)
    assert result.status == GoalStatus.STATUS_SUCCEEDED and result.result.battery_status == 'Empty', result
    assert set_state(probe, '/sim', 60.0).success


def test_new_goal_preempts_and_cancel_ends_the_goal(sim, probe):
    assert set_state(probe, '/sim', 50.0).success
    client = probe.action_client(BatterySim, '/sim/battery_simulator')
    first = probe.send_goal(client, BatterySim.Goal(charge_state=True))
    second = probe.send_goal(client, BatterySim.Goal(charge_state=False))
    ended = probe.result(first, 10.0)
    assert ended.status == GoalStatus.STATUS_ABORTED, ended
    assert ended.result.battery_status.startswith('Preempted at') and 'a new goal' in ended.result.battery_status
    assert status_after(probe, '/sim', lambda m: m.power_supply_status == DISCHARGING) is not None
    probe.cancel(second)
    cancelled = probe.result(second, 10.0)
    assert cancelled.status == GoalStatus.STATUS_CANCELED, cancelled
    assert 'cancel' in cancelled.result.battery_status


def test_charging_parameter_sets_the_mode_and_aborts_a_contradicted_goal(sim, probe):
    assert set_state(probe, '/sim', 50.0).success
    assert probe.set_parameter('/sim/battery_simulator', 'charging', True).successful
    assert status_after(probe, '/sim', lambda m: m.power_supply_status == CHARGING, 2.0) is not None, \
        'CHARGING within about a second of charging := true'
    client = probe.action_client(BatterySim, '/sim/battery_simulator')
    handle = probe.send_goal(client, BatterySim.Goal(charge_state=True))
    assert probe.set_parameter('/sim/battery_simulator', 'charging', False).successful
    result = probe.result(handle, 10.0)
    assert result.status == GoalStatus.STATUS_ABORTED, result
    assert 'charging was changed' in result.result.battery_status, result.result.battery_status
    refused = probe.set_parameter('/sim/battery_simulator', 'charging', 'yes')
    assert not refused.successful and refused.reason, 'a string for the bool charging is refused with a reason'
