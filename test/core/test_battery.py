"""The ROS-free battery (core/battery.py) that both front ends wrap: time base, loads, mode and goal
rules, controls, faults, live settings, the record. No ROS: a clock of the test's own, no sleeps."""
import math

import pytest

from battery_simulator.core.battery import (LIVE_PARAMETERS, UNREADABLE, Battery, BatteryError, Goal, GoalEnd,
                                            parse_mode)
from battery_simulator.core.battery_states import Mode, Status
from battery_simulator.core.config_files import preset
from battery_simulator.core.status_codes import FAULTS, SupplyStatus

NAN = math.nan


class Clock:
    def __init__(self, now=0.0):
        self.now = now

    def __call__(self):
        return self.now


class Log:
    def __init__(self):
        self.lines = []

    def _line(self, level):
        return lambda text, *args: self.lines.append((level, text % args if args else text))

    def __getattr__(self, name):
        if name.endswith('_throttle'):
            level = name[:-len('_throttle')]
            return lambda period_s, text, *args: self.lines.append((level, text % args if args else text))
        return self._line(name)


def battery(percentage=80.0, charging=False, sim_time=False, time_scale=1.0, preset_name='lg_hg2_3s1p', **kwargs):
    clock, log = Clock(1000.0 if sim_time else 0.0), Log()
    return Battery(preset(preset_name), percentage, charging, clock=clock, sim_time=sim_time, time_scale=time_scale,
                   log=log, **kwargs), clock, log


def level(b):
    return b.update().snapshot.percentage


def test_wall_time_is_scaled_and_sim_time_starts_where_the_clock_is():
    b, clock, _ = battery(time_scale=10.0)
    b.update()
    clock.now = 36.0   # 360 s of battery at 1.5 A of 2.781 Ah: 5.39 points
    points = 1.5 * 360.0 / 3600.0 / b.params.design_capacity_ah * 100.0
    assert 80.0 - level(b) == pytest.approx(points, rel=0.02)
    sim, clock, _ = battery(sim_time=True, time_scale=1000.0)
    start = level(sim)
    for clock.now in (1360.0, 1420.0, 1480.0, 1540.0, 1600.0, 1660.0, 1720.0):   # a start's first step counts once
        sim.update()                                                           # confirmed (issue 40: time_base)
    assert start - level(sim) == pytest.approx(2 * points, rel=0.02), 'under sim time the scale is ignored'


def test_a_jump_back_and_a_jump_forward_beyond_the_bound_drain_nothing():
    b, clock, _ = battery(sim_time=True, max_time_jump=3600.0)
    before = level(b)
    clock.now = 100.0                      # back: a restart
    update = b.update()
    assert update.time_jump == 'backwards' and update.snapshot.percentage == pytest.approx(before)
    clock.now = 50100.0                    # forward by hours: a second clock
    update = b.update()
    assert update.time_jump == 'forwards' and update.snapshot.percentage == pytest.approx(before)
    assert 'max_time_jump (3600 s)' in update.time_jump_warning(3600.0)
    assert '/a, /b' in update.time_jump_warning(3600.0, ['/b', '/a'])
    clock.now = 50460.0                    # an honest step counts again: 360 s at 1.5 A
    assert before - level(b) == pytest.approx(1.5 * 360.0 / 36.0 / b.params.design_capacity_ah, rel=0.02)
    clock.now = 0.0                        # a simulator not started (yet again): no clock, no jump, no drain
    assert b.update().time_jump is None


def test_motion_drains_its_energy_for_as_long_as_the_command_holds():
    b, clock, _ = battery()
    params = b.params
    b.update()
    b.on_cmd_vel(1.0, 0.0)
    clock.now = 0.4                         # held 0.4 s of its 0.5 s timeout
    with_motion = b.update().record.load_power_w
    assert with_motion == pytest.approx(params.motion_power_w(1.0, 0.0), rel=1e-6)
    clock.now = 10.0                        # timed out at 0.5 s: 0.1 s more of it over this update
    assert b.update().record.load_power_w == pytest.approx(params.motion_power_w(1.0, 0.0) * 0.1 / 9.6, rel=1e-6)
    with pytest.raises(BatteryError, match='beyond what a robot can do'):
        b.on_cmd_vel(NAN, 0.0)


def test_payload_loads_add_up_and_bad_ones_change_nothing():
    b, _, _ = battery()
    assert b.set_load('lidar', 8.0).endswith('payload loads now 8 W')
    assert b.set_load('arm', 12.0).endswith('payload loads now 20 W')
    for name, power in (('', 1.0), ('x', -1.0), ('x', NAN), ('x', 1e9)):
        with pytest.raises(BatteryError):
            b.set_load(name, power)
    assert b.set_load('lidar', 0.0).endswith('payload loads now 12 W')
    assert b.record().load_power_w == pytest.approx(12.0)


def test_the_contact_acts_on_its_changes_only():
    b, _, _ = battery()
    generation = b.mode_generation
    assert not b.change_contact(False, 'charger contact'), 'a first false changes nothing'
    assert b.change_contact(True, 'charger contact') and b.mode is Mode.CHARGE
    assert not b.change_contact(True, 'charger contact')
    assert b.change_contact(False, 'charger contact') and b.mode is Mode.DISCHARGE
    assert b.mode_generation == generation + 2


@pytest.mark.parametrize('value, mode', [(1, Mode.CHARGE), (True, Mode.CHARGE), (0, Mode.DISCHARGE),
                                         (False, Mode.DISCHARGE), (None, Mode.IDLE), (1.0, Mode.CHARGE)])
def test_mode_values(value, mode):
    assert parse_mode(value) is mode


def test_a_bad_mode_value_keeps_the_mode_and_is_said_once():
    b, _, log = battery()
    for value in (2, 2, 2, -1, 0.5, 'x', [1]):   # each new bad value said at once, a repeated one not again
        assert not b.follow_mode_value(value)
        assert b.mode is Mode.DISCHARGE
    errors = [text for level_, text in log.lines if level_ == 'error']
    assert len(errors) == 5 and "MyRobot/BatteryStatus = 2 is invalid" in errors[0], errors
    b.update(UNREADABLE)
    assert b.mode is Mode.DISCHARGE, 'an unreadable value changes nothing'


def test_goal_rules():
    b, clock, _ = battery(percentage=99.9, charging=True)
    goal = Goal(True)
    b.set_mode(goal.mode, 'goal')
    end = None
    while end is None and clock.now < 7200.0:
        clock.now += 30.0
        end = b.goal_end(goal, b.update().snapshot)
    assert (end.outcome, end.text) == (GoalEnd.SUCCEEDED, 'Full')
    goal = Goal(True)
    b.set_mode(Mode.CHARGE, 'goal')
    b.follow_mode_value(0)   # MyRobot/BatteryStatus changed from outside
    end = b.goal_end(goal, b.update().snapshot)
    assert end.outcome == GoalEnd.ABORTED and 'MyRobot/BatteryStatus was changed to discharge (parameter)' in end.text
    preempted = b.preempted('cancel')
    assert preempted.outcome == GoalEnd.PREEMPTED and preempted.text.startswith('Preempted at ')
    assert '(cancel, ' in preempted.text


def test_a_discharge_goal_ends_empty():
    b, clock, _ = battery(percentage=0.5)
    goal = Goal(False)
    end = None
    while end is None and clock.now < 3600.0:
        clock.now += 10.0
        end = b.goal_end(goal, b.update().snapshot)
    assert (end.outcome, end.text) == (GoalEnd.SUCCEEDED, 'Empty')


def test_set_state_and_reset():
    b, _, log = battery()
    assert b.set_state(30.0, NAN, NAN) == 'state set'
    assert b.record().percentage == pytest.approx(0.30)
    with pytest.raises(BatteryError, match=r'percentage = 130.0 is invalid: must be in \[0, 100\] %'):
        b.set_state(130.0)
    with pytest.raises(BatteryError, match='state_of_health'):
        b.set_state(NAN, NAN, 0.001)
    assert b.record().percentage == pytest.approx(0.30), 'a refusal changes nothing'
    b.inject_fault('overheat', True)
    message = b.reset()
    assert message == 'reset to 80.0 %, mode kept; faults cleared: overheat' and not b.faults
    assert b.record().percentage == pytest.approx(0.80)


def test_every_fault():
    b, clock, _ = battery(charging=True)
    with pytest.raises(BatteryError) as error:
        b.inject_fault('lightning', True)
    assert all(name in str(error.value) for name in FAULTS)
    b.inject_fault('charger_fault', True)
    before = b.update().snapshot.percentage
    clock.now += 600.0
    update = b.update()
    assert update.snapshot.status is Status.NOT_CHARGING and update.snapshot.percentage == pytest.approx(before)
    b.inject_fault('charger_fault', False)
    b.inject_fault('overheat', True)
    assert b.update().record.battery_fields()['power_supply_health'] == 2   # OVERHEAT
    b.inject_fault('overheat', False)
    b.inject_fault('sensor_dropout', True)
    assert b.update().record.sensor_dropout
    b.inject_fault('sensor_dropout', False)
    b.inject_fault('gauge_stuck', True)
    stuck = b.update().snapshot.percentage
    clock.now += 1200.0
    assert b.update().snapshot.percentage == stuck and b.update().snapshot.true_percentage > stuck


def test_measurement_noise_has_its_sigma_and_never_contradicts_the_status():
    b, _, _ = battery(noise_seed=3)
    b.inject_fault('measurement_noise', True)
    truth = b.update().snapshot
    readings = [b.update().record.battery_fields() for _ in range(400)]
    voltages = [r['voltage'] for r in readings]
    mean = sum(voltages) / len(voltages)
    sigma = math.sqrt(sum((v - mean) ** 2 for v in voltages) / len(voltages))
    assert sigma == pytest.approx(b.params.voltage_noise_v, rel=0.2) and abs(mean - truth.voltage_v) < 0.01
    assert all(r['current'] <= 0.0 for r in readings), 'discharging: never a positive current'


def test_live_settings():
    b, _, _ = battery()
    assert set(b.live_values()) == set(LIVE_PARAMETERS) | {'time_scale'}
    b.set_live('load_current_a', 2.0)
    assert b.params.load_current_a == 2.0
    for name, value in (('time_scale', 0.0), ('time_scale', NAN), ('load_current_a', -1.0), ('load_current_a', 'x'),
                        ('cells_series', 4)):
        with pytest.raises(BatteryError):
            b.set_live(name, value)
    assert b.params.load_current_a == 2.0 and b.time_scale == 1.0


def test_the_record_has_every_battery_state_field():
    b, _, _ = battery()
    fields = b.record().battery_fields()
    assert set(fields) == {'voltage', 'temperature', 'current', 'charge', 'capacity', 'design_capacity', 'percentage',
                           'power_supply_status', 'power_supply_health', 'power_supply_technology', 'present',
                           'cell_voltage', 'cell_temperature', 'location', 'serial_number'}
    assert 0.0 <= fields['percentage'] <= 1.0 and len(fields['cell_voltage']) == 3
    assert b.record().power_supply_status == SupplyStatus.DISCHARGING
    sim = b.record().sim_fields()
    assert sim['charging_state'] == 'Discharging' and sim['true_percentage'] == pytest.approx(80.0)


def test_prediction_copies_leave_the_battery_alone_and_state_round_trips():
    b, clock, _ = battery()
    b.update()
    clock.now = 100.0
    copy = b.model_for_prediction()
    copy.step(3600.0)
    assert b.update().snapshot.percentage > copy.snapshot().percentage + 10.0
    saved = b.export_state()
    again, _, _ = battery(percentage=20.0)
    again.resume(saved)
    assert again.record().percentage == pytest.approx(b.record().percentage)


def test_the_publishers_rule_over_the_latest_state():
    from types import SimpleNamespace

    from battery_simulator.core.latest_state import LatestState
    clock, log = Clock(0.0), Log()
    held = LatestState(3.0, log, 'the battery', 'the server', clock=clock)
    assert held.to_publish() is None and log.lines[-1] == ('info', 'waiting for the battery')
    state = SimpleNamespace(sensor_dropout=False)
    held.take(state)
    assert held.to_publish() is state and not held.stale()
    clock.now = 3.5
    assert held.to_publish() is state and held.stale(), 'stale: still the last known state'
    assert log.lines[-1][0] == 'warn' and 'no update from the server for 4 s' in log.lines[-1][1]
    held.take(SimpleNamespace(sensor_dropout=True))
    assert held.to_publish() is None and 'withheld' in log.lines[-1][1]
    fresh = SimpleNamespace(sensor_dropout=False)
    held.take(fresh)
    assert held.to_publish() is fresh and log.lines[-1] == ('info', 'battery state updates resumed')
