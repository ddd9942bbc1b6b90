"""Part 5 on ROS 2: a pack of differing groups and a fuel gauge that can be wrong, shown as on ROS 1."""
import math
import os
import time

import pytest
from sensor_msgs.msg import BatteryState
from std_srvs.srv import SetBool

from battery_simulator.msg import BatterySimState
from battery_simulator.srv import InjectFault, SetState
from ros2_probe import LATCHED, NodeProcess, Probe

AGED = os.path.join(os.path.dirname(os.path.abspath(__file__)), '..', '..', 'config', 'presets',
                    'lg_hg2_7s4p_aged.yaml')
NAN = math.nan


@pytest.fixture(scope='module')
def probe():
    probe = Probe('pack_probe')
    yield probe
    probe.close()


@pytest.fixture(scope='module')
def aged(probe):
    process = NodeProcess('battery_sim', '-r', '__ns:=/aged', '-p', 'config:=' + AGED, '-p', 'time_scale:=50.0',
                          '-p', 'initial_percentage:=80.0', '-p', 'rate:=5.0')
    assert probe.wait_for('/aged/battery_status', BatteryState, timeout_s=20.0) is not None, process.output()
    yield process
    assert process.stop() == 0, process.output()


def set_state(probe, ns, **fields):
    request = SetState.Request(percentage=NAN, temperature_c=NAN, state_of_health=NAN, gauge_error=NAN)
    for key, value in fields.items():
        setattr(request, key, float(value))
    return probe.call(SetState, ns + '/battery_simulator/set_state', request)


def latest_pair(probe, ns):
    """(what battery_status says, 0-100; the truth from battery_simulator/state), from one state message."""
    state = probe.wait_for(ns + '/battery_simulator/state', BatterySimState, timeout_s=5.0, qos=LATCHED,
                           since=time.monotonic())
    return 100.0 * state.battery.percentage, state.true_percentage


def test_each_group_has_its_own_cell_voltage(aged, probe):
    msg = probe.wait_for('/aged/battery_status', BatteryState, timeout_s=5.0, since=time.monotonic())
    assert len(msg.cell_voltage) == 7 and len(msg.cell_temperature) == 7
    assert max(msg.cell_voltage) - min(msg.cell_voltage) > 1e-4, list(msg.cell_voltage)


def test_the_robot_reads_the_gauge_and_the_truth_is_on_the_state_topic(aged, probe):
    read, true = latest_pair(probe, '/aged')
    assert read > true + 1.0, 'the aged gauge starts 2 points high and counts into a larger capacity'
    assert set_state(probe, '/aged', percentage=60.0, gauge_error=-4.0).success
    read, true = latest_pair(probe, '/aged')
    assert read == pytest.approx(true - 4.0, abs=0.3), (read, true)
    refused = set_state(probe, '/aged', gauge_error=200.0)
    assert not refused.success and 'gauge_error' in refused.message


def test_a_stuck_gauge_freezes_what_the_robot_reads(aged, probe):
    reply = probe.call(InjectFault, '/aged/battery_simulator/inject_fault',
                       InjectFault.Request(fault='gauge_stuck', active=True))
    assert reply.success, reply.message
    before_read, before_true = latest_pair(probe, '/aged')
    deadline = time.monotonic() + 10.0
    while time.monotonic() < deadline:
        read, true = latest_pair(probe, '/aged')
        if abs(true - before_true) > 0.5:
            break
    assert abs(true - before_true) > 0.5, 'the truth moves on (time x50)'
    assert read == pytest.approx(before_read, abs=1e-6), 'what the robot reads stays'
    assert probe.call(InjectFault, '/aged/battery_simulator/inject_fault',
                      InjectFault.Request(fault='gauge_stuck', active=False)).success


def test_an_ideal_gauge_refuses_a_gauge_error(probe):
    process = NodeProcess('battery_sim', '-r', '__ns:=/ideal')
    try:
        assert probe.wait_for('/ideal/battery_status', BatteryState, timeout_s=20.0) is not None, process.output()
        refused = set_state(probe, '/ideal', gauge_error=5.0)
        assert not refused.success and 'ideal' in refused.message
        assert set_state(probe, '/ideal', percentage=50.0).success, 'gauge_error NaN: nothing asked of the gauge'
        assert probe.call(SetBool, '/ideal/battery_simulator/set_charging', SetBool.Request(data=True)).success
    finally:
        assert process.stop() == 0, process.output()
