"""The test controls (set_load, set_charging, set_state, reset, inject_fault, predict), the faults, live values
refused with a reason, transient-local low/critical and the diagnostics against battery_sim (ROS 2 twin of
test/ros1/operations.test). One battery_sim in /sim (conftest.py's sim); every wait has a bound."""
import time

from diagnostic_msgs.msg import DiagnosticArray
from rcl_interfaces.msg import ParameterType
from rcl_interfaces.srv import DescribeParameters
from sensor_msgs.msg import BatteryState
from std_msgs.msg import Bool
from std_srvs.srv import SetBool, Trigger

from battery_simulator.core.status_codes import DIAGNOSTIC_KEYS, FAULTS
from battery_simulator.core.status_rules import URGENT_GAP_S
from battery_simulator.srv import InjectFault, Predict, SetLoad
from ros2_probe import CHARGING, DISCHARGING, LATCHED, NOT_CHARGING, Probe, set_state, status_after


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


def test_the_progress_line_as_on_ros_1(sim, probe):
    """battery_sim says its level a whole percent at a time, as battery_sim_server.py does (core/server_log.py;
    before issue 41 ROS 2 had no progress line)."""
    assert set_state(probe, '/sim', 60.0).success
    deadline = time.monotonic() + 20.0   # 'Discharging... 59 % (...)' or 'Charging... 61 % (...)'
    while not any(line in sim.output() for line in ('ing... 59 %', 'ing... 60 %', 'ing... 61 %')):
        assert time.monotonic() < deadline, 'no progress line in 20 s:\n' + sim.output()[-2000:]
        time.sleep(0.1)


def test_contact_flapping_is_coalesced_as_on_ros_1(sim, probe):
    """A flapping contact (each change a send-now battery_status) goes out as at most one message every
    URGENT_GAP_S plus the rate's (ROS 1's test_hardening bound), and the last state is the one published."""
    contact = probe.node.create_publisher(Bool, '/sim/charger_contact', 100)
    deadline = time.monotonic() + 10.0
    while contact.get_subscription_count() == 0 and time.monotonic() < deadline:
        time.sleep(0.05)
    received = probe.follow('/sim/battery_status', BatteryState)
    flips, seen, started = 0, len(received), time.monotonic()
    while time.monotonic() - started < 2.0:
        contact.publish(Bool(data=flips % 2 == 0))
        flips += 1
        time.sleep(0.001)
    contact.publish(Bool(data=False))   # ends disconnected: discharging
    time.sleep(0.2)   # the changes still queued are taken meanwhile: counted with the time they take
    messages, elapsed_s = len(received) - seen, time.monotonic() - started
    allowed = elapsed_s / URGENT_GAP_S + elapsed_s * 5.0 + 5
    assert messages <= allowed, '%d battery_status in %.1f s for %d contact changes (at most %d)' % (
        messages, elapsed_s, flips, allowed)
    assert status_after(probe, '/sim', lambda m: m.power_supply_status == DISCHARGING, 2.0) is not None
    probe.node.destroy_publisher(contact)


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


def test_descriptors_state_type_range_and_description(sim, probe):
    """Part 4: parameters declared with descriptors (type, range, description); a value out of the range is
    refused with the package's reason, the old value kept."""
    described = probe.call(DescribeParameters, '/sim/battery_simulator/describe_parameters',
                           DescribeParameters.Request(names=['time_scale', 'initial_percentage'])).descriptors
    for descriptor, (low, high) in zip(described, ((0.0, 10000.0), (0.0, 100.0))):
        assert descriptor.description and descriptor.type == ParameterType.PARAMETER_DOUBLE, descriptor
        assert [(r.from_value, r.to_value) for r in descriptor.floating_point_range] == [(low, high)], descriptor
    refused = probe.set_parameter('/sim/battery_simulator', 'time_scale', 20000.0)
    assert not refused.successful and 'time_scale' in refused.reason and 'keeping' in refused.reason, refused


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
