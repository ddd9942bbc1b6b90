"""Part 5 on ROS 2: a pack of differing groups and a fuel gauge that can be wrong, shown as on ROS 1."""
import math
import os
import re
import time

import pytest
from diagnostic_msgs.msg import DiagnosticArray
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


# -- Part 9: a learning gauge, put on a pack by gauge_config --------------------------------------------

HERE = os.path.dirname(os.path.abspath(__file__))
ASLEEP = os.path.join(HERE, '..', 'config', 'learning_gauge.yaml')
IMPEDANCE_TRACK = os.path.join(HERE, '..', '..', 'config', 'presets', 'gauge_impedance_track.yaml')


def gauge_diagnostics(probe, predicate, timeout_s=10.0):
    """The gauge's diagnostics values of /learning's battery once ``predicate(values)`` holds (None: never)."""
    array = probe.wait_for('/diagnostics', DiagnosticArray, lambda a: any(
        s.name == 'learning/battery_state_pub: Battery' and predicate({v.key: v.value for v in s.values})
        for s in a.status), timeout_s, since=time.monotonic())
    if array is None:
        return None
    return next({v.key: v.value for v in s.values} for s in array.status
                if s.name == 'learning/battery_state_pub: Battery')


def test_a_learning_gauge_reads_a_rest_logs_the_correction_once_and_counts_it(probe):
    process = NodeProcess('battery_sim', '-r', '__ns:=/learning', '-p', 'config:=' + ASLEEP, '-p',
                          'gauge_config:=' + IMPEDANCE_TRACK, '-p', 'time_scale:=500.0', '-p',
                          'initial_percentage:=50.0', '-p', 'rate:=5.0')
    try:
        assert probe.wait_for('/learning/battery_status', BatteryState, timeout_s=20.0) is not None, process.output()
        values = gauge_diagnostics(probe, lambda v: 'Gauge Corrections' in v)
        assert values is not None and values['Gauge Corrections'] == '0' and values['Gauge Learned'] == 'false'
        assert float(values['Gauge Full Capacity (Ah)']) == pytest.approx(2.781, abs=1e-3)
        assert set_state(probe, '/learning', percentage=50.0, gauge_error=5.0).success
        read, true = latest_pair(probe, '/learning')
        assert read == pytest.approx(true + 5.0, abs=0.3)
        # 30 min of battery at x500: 3.6 s; then read every 100 s (0.2 s): one correction, logged once
        values = gauge_diagnostics(probe, lambda v: v.get('Gauge Corrections') == '1', timeout_s=30.0)
        assert values is not None, process.output()
        read, true = latest_pair(probe, '/learning')
        assert abs(read - true) <= 1.0, (read, true)
        state = probe.wait_for('/learning/battery_simulator/state', BatterySimState, timeout_s=5.0, qos=LATCHED,
                               since=time.monotonic())
        assert state.gauge_corrections == 1 and not state.gauge_learned
        assert state.gauge_full_capacity_ah == pytest.approx(2.781, abs=1e-3)
        assert process.wait_for_output('gauge ocv_rest: ', 5.0), process.output()
        old, new = map(float, re.search(r'gauge ocv_rest: ([\d.]+) % -> ([\d.]+) % \(rest of \d+ min',
                                        process.output()).groups())
        assert 4.0 <= old - new <= 7.0, process.output()   # the 5 points, and the hysteresis' 0.65
        time.sleep(1.0)   # more rest readings (every 0.2 s): none of them is a correction to log
        assert process.output().count('gauge ocv_rest') == 1, process.output()
    finally:
        assert process.stop() == 0, process.output()


def test_a_bad_gauge_config_is_one_line_and_exit_2(tmp_path):
    pack_only = tmp_path / 'pack.yaml'
    pack_only.write_text('preset: lg_hg2_3s1p\n')
    process = NodeProcess('battery_sim', '-r', '__ns:=/bad_gauge', '-p', 'gauge_config:=%s' % pack_only)
    assert process.wait(30.0) == 2, process.output()
    assert 'gauge_config' in process.output() and 'has no gauge section' in process.output()
    assert 'Traceback' not in process.output()


def test_the_demo_takes_the_learning_gauges():
    """battery_demo -p gauge:=...: a value it does not know is one line naming the four (exit 2)."""
    process = NodeProcess('battery_demo', '-r', '__ns:=/demo_gauge', '-p', 'gauge:=bq99')
    assert process.wait(30.0) == 2, process.output()
    assert 'ideal, realistic, impedance_track or modelgauge' in process.output(), process.output()
    assert 'Traceback' not in process.output()
