"""The Part 1-2 battery behaviours against the ROS 2 nodes (battery_sim, battery_state_pub alone,
battery_fleet, battery_sim_client), driven from pytest: no ros2cli or launch wheels exist.

Each process runs in a namespace of its own; every wait has a bound."""
import json
import math
import os
import signal
import subprocess
import time

import pytest
from action_msgs.msg import GoalStatus
from diagnostic_msgs.msg import DiagnosticArray
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import BatteryState
from std_msgs.msg import Bool
from std_srvs.srv import SetBool, Trigger

from battery_simulator.action import BatterySim
from battery_simulator.core.status_codes import DIAGNOSTIC_KEYS, FAULTS
from battery_simulator.msg import BatteryFleetState
from battery_simulator.srv import InjectFault, Predict, SetLoad, SetState
from ros2_probe import LATCHED, NodeProcess, Probe, udp_sockets

NAN = math.nan
CHARGING, DISCHARGING, NOT_CHARGING, FULL = (BatteryState.POWER_SUPPLY_STATUS_CHARGING,
                                             BatteryState.POWER_SUPPLY_STATUS_DISCHARGING,
                                             BatteryState.POWER_SUPPLY_STATUS_NOT_CHARGING,
                                             BatteryState.POWER_SUPPLY_STATUS_FULL)


@pytest.fixture(scope='module')
def probe():
    probe = Probe()
    yield probe
    probe.close()


@pytest.fixture(scope='module')
def sim(probe):
    """One battery_sim in /sim, fast (time x200, 20 Hz updates, battery_status at 5 Hz)."""
    process = NodeProcess('battery_sim', '-r', '__ns:=/sim', '-p', 'time_scale:=100.0', '-p', 'update_rate:=20.0',
                          '-p', 'rate:=5.0')
    assert probe.wait_for('/sim/battery_status', BatteryState, timeout_s=20.0) is not None, \
        'no battery_status from battery_sim within 20 s:\n' + process.output()
    yield process
    assert process.stop() == 0, 'battery_sim did not end cleanly on SIGINT:\n' + process.output()
    assert 'Traceback' not in process.output(), process.output()


def set_state(probe, ns, percentage=NAN, temperature_c=NAN, state_of_health=NAN):
    return probe.call(SetState, ns + '/battery_simulator/set_state', SetState.Request(
        percentage=float(percentage), temperature_c=float(temperature_c), state_of_health=float(state_of_health)))


def status_after(probe, ns, predicate, timeout_s=5.0, since=None):
    """The first battery_status of ``ns`` after ``since`` (default now) that satisfies ``predicate``, or None."""
    return probe.wait_for(ns + '/battery_status', BatteryState, predicate, timeout_s,
                          since=time.monotonic() if since is None else since)


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


def test_services(sim, probe):
    ns = '/sim/battery_simulator/'
    ok = probe.call(SetLoad, ns + 'set_load', SetLoad.Request(name='lidar', power_w=8.0))
    assert ok.success and 'lidar' in ok.message
    bad = probe.call(SetLoad, ns + 'set_load', SetLoad.Request(name='', power_w=8.0))
    assert not bad.success and bad.message
    assert probe.call(SetLoad, ns + 'set_load', SetLoad.Request(name='lidar', power_w=0.0)).success
    assert probe.call(SetBool, ns + 'set_charging', SetBool.Request(data=True)).success
    assert status_after(probe, '/sim', lambda m: m.power_supply_status == CHARGING, 2.0) is not None
    assert probe.call(SetBool, ns + 'set_charging', SetBool.Request(data=False)).success
    before = time.monotonic()
    assert set_state(probe, '/sim', 37.0).success
    assert status_after(probe, '/sim', lambda m: abs(m.percentage - 0.37) < 0.001, 2.0, before) is not None, \
        'the next battery_status shows the state set'
    assert probe.call(SetBool, ns + 'set_charging', SetBool.Request(data=True)).success
    refused = set_state(probe, '/sim', state_of_health=0.001)
    assert not refused.success and 'state_of_health' in refused.message
    reset = probe.call(Trigger, ns + 'reset', Trigger.Request())
    assert reset.success and 'reset to 100.0 %' in reset.message, reset.message
    unknown = probe.call(InjectFault, ns + 'inject_fault', InjectFault.Request(fault='lightning', active=True))
    assert not unknown.success and all(name in unknown.message for name in FAULTS), unknown.message
    answer = probe.call(Predict, ns + 'predict', Predict.Request(duration_s=[600.0], power_w=[10.0]))
    assert answer.success and answer.feasible and 0 < answer.end_percentage < 100, answer
    bad_plan = probe.call(Predict, ns + 'predict', Predict.Request(duration_s=[-1.0]))
    assert not bad_plan.success and bad_plan.message


def test_faults(sim, probe):
    ns = '/sim/battery_simulator/'

    def fault(name, active):
        reply = probe.call(InjectFault, ns + 'inject_fault', InjectFault.Request(fault=name, active=active))
        assert reply.success, reply.message

    assert set_state(probe, '/sim', 50.0).success
    fault('charger_fault', True)
    assert probe.call(SetBool, ns + 'set_charging', SetBool.Request(data=True)).success
    assert status_after(probe, '/sim', lambda m: m.power_supply_status == NOT_CHARGING, 2.0) is not None, \
        'charger_fault: NOT_CHARGING while connected'
    fault('charger_fault', False)
    assert probe.call(SetBool, ns + 'set_charging', SetBool.Request(data=False)).success
    fault('overheat', True)
    assert status_after(probe, '/sim', lambda m: m.power_supply_health ==
                        BatteryState.POWER_SUPPLY_HEALTH_OVERHEAT, 3.0) is not None, 'overheat: health OVERHEAT'
    fault('overheat', False)
    fault('measurement_noise', True)
    voltages = set()
    deadline = time.monotonic() + 5.0
    while len(voltages) < 3 and time.monotonic() < deadline:
        msg = status_after(probe, '/sim', lambda m: True, 2.0)
        voltages.add(round(msg.voltage, 4))
    assert len(voltages) >= 3, 'measurement_noise: the voltage varies (%s)' % voltages
    fault('measurement_noise', False)
    fault('sensor_dropout', True)
    time.sleep(0.5)   # what is already on its way may still arrive: then nothing more for a second
    assert status_after(probe, '/sim', lambda m: True, 1.0) is None, 'sensor_dropout: battery_status stops'
    fault('sensor_dropout', False)
    assert status_after(probe, '/sim', lambda m: True, 3.0) is not None, 'battery_status back after the dropout'
    assert probe.call(Trigger, ns + 'reset', Trigger.Request()).success


def test_live_values_refused_with_a_reason(sim, probe):
    refused = probe.set_parameter('/sim/battery_simulator', 'time_scale', -1.0)
    assert not refused.successful and 'time_scale' in refused.reason, refused
    refused = probe.set_parameter('/sim/battery_simulator', 'load_current_a', -5.0)
    assert not refused.successful and 'load_current_a' in refused.reason, refused
    read_only = probe.set_parameter('/sim/battery_simulator', 'update_rate', 5.0)
    assert not read_only.successful, 'update_rate acts only at start-up (read-only)'
    accepted = probe.set_parameter('/sim/battery_simulator', 'load_power_w', 5.0)
    assert accepted.successful, accepted
    assert probe.set_parameter('/sim/battery_simulator', 'load_power_w', 0.0).successful


def test_low_and_critical_are_transient_local(sim, probe):
    assert set_state(probe, '/sim', 3.0).success
    late = Probe('late_subscriber')
    try:
        low = late.wait_for('/sim/battery_low', Bool, lambda m: m.data, 5.0, qos=LATCHED)
        critical = late.wait_for('/sim/battery_critical', Bool, lambda m: m.data, 5.0, qos=LATCHED)
    finally:
        late.close()
    assert low is not None and critical is not None, 'a late subscriber gets battery_low/critical true'
    assert set_state(probe, '/sim', 80.0).success


def hold_the_level(probe, ns, hold):
    """A connected charger that delivers nothing (charger_fault): the level stays where set_state puts it."""
    assert probe.call(InjectFault, ns + '/battery_simulator/inject_fault',
                      InjectFault.Request(fault='charger_fault', active=hold)).success
    assert probe.call(SetBool, ns + '/battery_simulator/set_charging', SetBool.Request(data=hold)).success


def test_diagnostics_keys_and_levels(sim, probe):
    hold_the_level(probe, '/sim', True)

    def battery_status(level_percentage):
        assert set_state(probe, '/sim', level_percentage).success
        array = probe.wait_for('/diagnostics', DiagnosticArray, lambda a: any(
            s.name == 'sim/battery_state_pub: Battery' and abs(float(
                {v.key: v.value for v in s.values}.get('Percentage (%)', -1)) - level_percentage) < 0.5
            for s in a.status), 5.0, since=time.monotonic())
        assert array is not None, 'no diagnostics at %g %%' % level_percentage
        return next(s for s in array.status if s.name == 'sim/battery_state_pub: Battery')

    ok = battery_status(80.0)
    assert [v.key for v in ok.values] == list(DIAGNOSTIC_KEYS[:len(ok.values)]) and len(ok.values) >= 12
    assert ok.level == b'\x00' and ok.hardware_id, ok
    assert battery_status(12.0).level == b'\x01', 'WARN below the low level'
    assert battery_status(3.0).level == b'\x02', 'ERROR below the critical level'
    hold_the_level(probe, '/sim', False)
    assert set_state(probe, '/sim', 80.0).success


def test_sim_time_backwards_jump_restarts_the_time_base(probe):
    clock = probe.node.create_publisher(Clock, '/clock', 10)

    def tick(seconds):
        clock.publish(Clock(clock=probe.node.get_clock().now().__class__(seconds=seconds).to_msg()))

    process = NodeProcess('battery_sim', '-r', '__ns:=/simtime', '-p', 'use_sim_time:=true',
                          '-p', 'initial_percentage:=80.0')
    try:
        assert probe.wait_for('/simtime/battery_status', BatteryState, timeout_s=20.0) is not None, process.output()
        for seconds in (1.7e9, 1.7e9 + 0.5):
            tick(seconds)
            time.sleep(0.3)
        start = status_after(probe, '/simtime', lambda m: True).percentage
        assert abs(start - 0.80) < 0.002, 'the first /clock value is a start, not elapsed time (%g)' % start
        tick(100.0)   # back: a restart, nothing drained
        time.sleep(0.3)
        tick(101.0)
        time.sleep(0.3)
        after = status_after(probe, '/simtime', lambda m: True)
        assert after is not None, 'battery_status keeps flowing after the jump'
        assert abs(after.percentage - start) < 0.002, 'the jump drained nothing (%g -> %g)' % (start, after.percentage)
        tick(401.0)   # 300 s at 1.5 A of 3 Ah: about 4 points
        time.sleep(0.5)
        later = status_after(probe, '/simtime', lambda m: True)
        assert 0.02 < start - later.percentage < 0.07, (start, later.percentage)
        assert 'moved backwards' in process.output()
    finally:
        probe.node.destroy_publisher(clock)
        assert process.stop() == 0, process.output()


def test_resume_after_sigkill(probe, tmp_path):
    state_file = str(tmp_path / 'battery.json')
    args = ('-r', '__ns:=/resume', '-p', 'state_file:=' + state_file, '-p', 'time_scale:=1.0')
    process = NodeProcess('battery_sim', *args)
    try:
        assert probe.wait_for('/resume/battery_status', BatteryState, timeout_s=20.0) is not None, process.output()
        assert set_state(probe, '/resume', 42.0, state_of_health=0.9).success
        deadline = time.monotonic() + 10.0
        while time.monotonic() < deadline:
            try:
                with open(state_file, encoding='utf-8') as stream:
                    if abs(json.load(stream)['state_of_charge'] - 0.42) < 0.005:
                        break
            except (OSError, ValueError):
                pass
            time.sleep(0.05)
        else:
            raise AssertionError('the state file never held 42 %')
    finally:
        process.stop(signal.SIGKILL)
    again = NodeProcess('battery_sim', *args)
    try:
        msg = probe.wait_for('/resume/battery_status', BatteryState, timeout_s=20.0, since=time.monotonic())
        assert msg is not None, again.output()
        assert abs(msg.percentage - 0.42) < 0.01, 'resumed within 1 %% of 42 %% (%g)' % msg.percentage
        assert abs(msg.capacity / msg.design_capacity - 0.9) < 0.01, 'state of health kept'
        assert 'resumed from' in again.output()
    finally:
        again.stop()


@pytest.mark.parametrize('ros_args, named', [
    (('-p', 'time_scale:=-1.0'), 'time_scale'),
    (('-p', 'initial_percentage:=120.0'), 'initial_percentage'),
    (('-p', 'config:=/nonexistent.yaml'), 'config'),
    (('-p', 'critical_percentage:=0.5'), 'critical_percentage'),
    (('-p', 'load_current_a:=-3.0'), 'load_current_a'),
])
def test_bad_startup_value_ends_with_one_line(ros_args, named):
    process = NodeProcess('battery_sim', '-r', '__ns:=/bad', *ros_args)
    try:
        status = process.wait(20.0)
        assert status not in (None, 0), 'a bad %s ends the process non-zero (%r)' % (named, status)
        fatal = [line for line in process.output().splitlines() if 'invalid' in line]
        assert len(fatal) == 1 and named in fatal[0], process.output()
        assert 'Traceback' not in process.output(), process.output()
    finally:
        process.stop()


def test_tutorial_node_alone_runs_a_battery(probe):
    process = NodeProcess('battery_state_pub', '-r', '__ns:=/tutorial', '-p', 'wait_s:=0.5',
                          '-p', 'time_scale:=500.0')
    try:
        first = probe.wait_for('/tutorial/battery_status', BatteryState, timeout_s=20.0)
        assert first is not None, process.output()
        later = probe.wait_for('/tutorial/battery_status', BatteryState,
                               lambda m: m.percentage < first.percentage - 0.001, 10.0)
        assert later is not None and later.power_supply_status == DISCHARGING, 'alone, its battery discharges'
        assert later.voltage > 9.0, 'a physical pack voltage (3 cells), not the tutorial\'s decaying 9 V'
        assert 'a battery of its own' in process.output()
    finally:
        assert process.stop() == 0, process.output()


def test_fleet_of_ten_in_one_process(probe):
    process = NodeProcess('battery_fleet', '-p', 'robots:=10', '-p', 'prefix:=fleetbot', '-p', 'time_scale:=50.0')
    try:
        for k in range(10):
            msg = probe.wait_for('/fleetbot%d/battery_status' % k, BatteryState, timeout_s=30.0)
            assert msg is not None, 'fleetbot%d/battery_status:\n%s' % (k, process.output())
        fleet = probe.wait_for('/battery_fleet/states', BatteryFleetState, lambda m: len(m.names) == 10, 10.0)
        assert fleet is not None and sorted(fleet.names) == sorted('fleetbot%d' % k for k in range(10))
        assert probe.set_parameter('/fleetbot3/battery_simulator', 'charging', True).successful
        assert status_after(probe, '/fleetbot3', lambda m: m.power_supply_status == CHARGING, 2.0) is not None
        other = status_after(probe, '/fleetbot4', lambda m: True)
        assert other.power_supply_status == DISCHARGING, 'one robot\'s charging is its own'
        client = probe.action_client(BatterySim, '/fleetbot5/battery_simulator')
        assert set_state(probe, '/fleetbot5', 99.5).success
        result = probe.result(probe.send_goal(client, BatterySim.Goal(charge_state=True)), 60.0)
        assert result.result.battery_status == 'Full'
        assert len(process.output().splitlines()) < 40, 'a fleet does not log per level'
    finally:
        assert process.stop() == 0, process.output()


def test_client_charges_to_full(sim, probe):
    assert set_state(probe, '/sim', 99.5).success
    done = subprocess.run(['battery_sim_client', '1', '--ros-args', '-r', '__ns:=/sim'], capture_output=True,
                          text=True, timeout=60)
    assert done.returncode == 0, done.stdout + done.stderr
    assert 'Result: Full (succeeded)' in done.stdout, done.stdout
    usage = subprocess.run(['battery_sim_client', 'maybe'], capture_output=True, text=True, timeout=30)
    assert usage.returncode == 2 and 'usage' in usage.stderr


def test_a_restart_resumes_the_learning_gauges_learned_capacity(probe, tmp_path):
    """Issue 43: the state file carries what the gauge learned (a real gauge's flash). A state saved with a
    learned capacity 20 % below the configured belief: battery_status' capacity (the gauge's full charge
    capacity) is the learned one after the start, and the file written at the stop still holds it."""
    from battery_simulator.core.battery_states import Mode
    from battery_simulator.core.config_files import from_mapping
    from battery_simulator.core.pack import make_model
    config = tmp_path / 'learning.yaml'
    config.write_text('preset: lg_hg2_3s1p\ngauge: {model: learning}\n', encoding='utf-8')
    model = make_model(from_mapping({'preset': 'lg_hg2_3s1p', 'gauge': {'model': 'learning'}}), 0.6, Mode.IDLE)
    configured_ah = model.gauge_reading()[2]
    model.gauge.capacity_as *= 0.8
    model.gauge.learned = True
    model.step(0.0)
    state_file = tmp_path / 'battery.json'
    state_file.write_text(json.dumps(model.export_state()), encoding='utf-8')
    process = NodeProcess('battery_sim', '-r', '__ns:=/learned', '-p', 'config:=' + str(config),
                          '-p', 'state_file:=' + str(state_file), '-p', 'time_scale:=1.0')
    try:
        msg = probe.wait_for('/learned/battery_status', BatteryState, timeout_s=20.0)
        assert msg is not None, process.output()
        # (the full charge capacity at the start's load: a few % below the rest's; the fresh belief: 25 % above)
        assert msg.capacity == pytest.approx(0.8 * configured_ah, rel=0.05), (msg.capacity, configured_ah)
    finally:
        assert process.stop() == 0, process.output()
    saved = json.loads(state_file.read_text(encoding='utf-8'))
    assert saved['gauge_learned'] is True
    assert saved['gauge_capacity_ah'] == pytest.approx(model.gauge.capacity_ah, rel=1e-9)
