"""A full pack on the dock (interface Part 7, issue 35), and drivers' conventions on battery_status.

opennav_docking's SimpleChargingDock calls a robot charging when battery_status's current exceeds
0.5 A, and its docking server waits 5 s after contact for that; hasStoppedCharging (undocking) wants
it below 0.5 A again. A full pack on a real dock is held full by its charger, which carries the
robot's own load: these tests check that on every shipped config, in the ROS-free core both front
ends wrap.
"""
import math
from dataclasses import replace
from types import SimpleNamespace

import pytest

from battery_simulator.core.battery import Battery
from battery_simulator.core.battery_model import BatteryModel
from battery_simulator.core.battery_states import Mode, Status
from battery_simulator.core.config_files import default_config_path, from_mapping, load_yaml, preset, preset_names
from battery_simulator.core.parameter_rules import ParameterError
from battery_simulator.core.prediction import Segment, predict
from battery_simulator.core.status_rules import StatusRules

#: SimpleChargingDock's charging_threshold (A) and the docking server's wait for charge after contact (s)
CHARGING_THRESHOLD_A = 0.5
WAIT_CHARGE_S = 5.0


def shipped_configs():
    """(name, parameters) of every preset and config the package ships."""
    configs = [(name, preset(name)) for name in preset_names()]
    for path in (default_config_path(), default_config_path().parent / 'battery_realistic.yaml'):
        configs.append((path.name, load_yaml(path)))
    return configs


SHIPPED = shipped_configs()


class Clock:
    """A clock a test moves by hand (the front ends' time, time_scale 1)."""

    def __init__(self):
        self.now = 0.0

    def __call__(self):
        return self.now


def battery_at(params, percentage):
    clock = Clock()
    battery = Battery(params, initial_percentage=50.0, clock=clock)
    battery.set_state(percentage)   # the gauge, if any, at the truth
    battery.update(0)               # discharging: the robot's base load
    return battery, clock


def records_for(battery, clock, seconds):
    """One update a second for ``seconds`` s: their snapshots."""
    snapshots = []
    for _ in range(int(seconds)):
        clock.now += 1.0
        snapshots.append(battery.update().snapshot)
    return snapshots


@pytest.mark.parametrize('name, params', SHIPPED, ids=[name for name, _ in SHIPPED])
def test_contact_with_a_full_pack_shows_the_charger_within_5_s_and_leaving_ends_it(name, params):
    battery, clock = battery_at(params, 100.0)
    assert battery.change_contact(True, 'charger_contact')
    at_contact = battery.record().snapshot
    assert at_contact.status is Status.FULL and at_contact.current_a > CHARGING_THRESHOLD_A, (
        '%s: a full pack on the dock shows %.3f A (%s): opennav_docking needs > %g A'
        % (name, at_contact.current_a, at_contact.status, CHARGING_THRESHOLD_A))
    held = records_for(battery, clock, 3600)   # an hour on the dock
    assert all(s.status is Status.FULL and s.current_a > CHARGING_THRESHOLD_A for s in held), (
        name, min(s.current_a for s in held))
    assert held[-1].true_percentage == 100.0 and held[-1].percentage == pytest.approx(100.0, abs=0.1), (
        name, 'held full for an hour', held[-1].true_percentage, held[-1].percentage)
    base_load_a = params.load_current_a + params.load_power_w / held[-1].voltage_v
    assert held[-1].current_a == pytest.approx(base_load_a, rel=1e-9), (name, 'the charger carries the base load')
    assert battery.change_contact(False, 'charger_contact')
    off = records_for(battery, clock, WAIT_CHARGE_S)
    assert all(s.current_a < CHARGING_THRESHOLD_A for s in [battery.record().snapshot] + off), name
    assert off[0].status is Status.DISCHARGING and off[0].current_a == pytest.approx(-base_load_a, rel=0.01), name


@pytest.mark.parametrize('name, params', SHIPPED, ids=[name for name, _ in SHIPPED])
def test_docking_just_below_full_charges_then_is_held_full(name, params):
    """The issue's 99.7 %: after 30 s of driving the CV charge flows at once, and once it ends the pack is held
    full at the load's current (not 0 A): the status says which (CHARGING with the cells' current, FULL with
    the charger's)."""
    battery, clock = battery_at(params, 99.7)
    records_for(battery, clock, 30)
    battery.change_contact(True, 'charger_contact')
    seen = [battery.record().snapshot] + records_for(battery, clock, 600)
    assert all(s.current_a > CHARGING_THRESHOLD_A for s in seen[:int(WAIT_CHARGE_S) + 1]), (
        name, [round(s.current_a, 3) for s in seen[:6]])
    statuses = [s.status for s in seen]
    first_full = statuses.index(Status.FULL)
    assert set(statuses[:first_full]) == {Status.CHARGING} and set(statuses[first_full:]) == {Status.FULL}, name
    assert all(s.current_a > 0.0 for s in seen), name
    assert seen[first_full - 1].current_a < seen[first_full].current_a, (
        name, 'the taper ends near the termination current, then the charger holds the pack at the load')


def test_held_full_puts_no_charge_into_the_cells_and_follows_the_load():
    params = preset('lg_hg2_7s4p')
    model = BatteryModel(params, state_of_charge=1.0, mode=Mode.CHARGE)
    throughput, state = model.throughput_as, model.export_state()
    model.set_extra_load('payload', power_w=50.0)
    model.step(3600.0)
    assert model.status is Status.FULL and model.throughput_as == throughput, 'nothing into or out of the cells'
    assert model.state_of_charge == 1.0 and model.discharged_ah == state['discharged_ah'], 'no cycle counted'
    assert model.cell_current_a == 0.0
    assert model.current_a == pytest.approx(params.load_current_a + 50.0 / model.voltage_v, rel=1e-12), \
        'the base load and the payload, at the pack voltage'


def test_a_charger_that_switches_off_at_full_shows_0_a_as_before():
    """charger_holds_full: false: the charger of a dock that does not power the robot (0 A at Full: what
    SimpleChargingDock cannot tell from no contact; a case for testing a docking controller)."""
    params = replace(preset('lg_hg2_3s1p'), charger_holds_full=False)
    model = BatteryModel(params, state_of_charge=1.0, mode=Mode.CHARGE)
    model.step(10.0)
    assert (model.status, model.current_a) == (Status.FULL, 0.0)


def test_a_charger_fault_on_the_dock_shows_no_current_even_when_full():
    battery, clock = battery_at(preset('lg_hg2_3s1p'), 100.0)
    battery.inject_fault('charger_fault', True)
    battery.change_contact(True, 'charger_contact')
    snapshot = records_for(battery, clock, 5)[-1]
    assert (snapshot.status, snapshot.current_a) == (Status.NOT_CHARGING, 0.0)


def test_held_full_needs_the_charger_mode():
    """Full in a replay (no charger mode: the profile's own current) or idle shows what flows: 0 A."""
    model = BatteryModel(preset('lg_hg2_3s1p'), state_of_charge=0.999, mode=Mode.IDLE)
    for _ in range(100):
        model.step(10.0, current_a=1.5)
    assert model.status is Status.FULL and model.current_a == 0.0


def test_predict_with_charge_to_agrees_with_the_battery_on_the_dock():
    """predict's charge time from 95 % equals the running battery's time to Full on the dock (within 2 %),
    and a full pack's charge is done at once."""
    params = preset('lg_hg2_3s1p')
    model = BatteryModel(params, state_of_charge=0.95, mode=Mode.IDLE)
    predicted = predict(model, [Segment(60.0)], charge_to_percentage=100.0)
    battery, clock = battery_at(params, 95.0)
    records_for(battery, clock, 60)
    battery.change_contact(True, 'charger_contact')
    seconds = 0
    while battery.record().snapshot.status is not Status.FULL:
        clock.now += 1.0
        battery.update()
        seconds += 1
        assert seconds < 7200, 'no Full within 2 h'
    assert seconds == pytest.approx(predicted.charge_time_s, rel=0.02), (seconds, predicted.charge_time_s)
    full = predict(BatteryModel(params, state_of_charge=1.0, mode=Mode.CHARGE), [], charge_to_percentage=100.0)
    assert full.charge_time_s == 0.0 and full.end_percentage == 100.0


# -- conventions ------------------------------------------------------------------------------------

def record_of(conventions, mode=Mode.DISCHARGE):
    params = replace(preset('lg_hg2_3s1p'), conventions=conventions)
    battery = Battery(params, initial_percentage=80.0, charging=mode is Mode.CHARGE, clock=Clock())
    return battery.update().record


class _Log:
    def __getattr__(self, name):
        return lambda *args: None


def published_battery_fields(record):
    """What battery_status carries for ``record``, the way the front ends make it: the record's messages
    (BatteryState in battery_fields, the rest in sim_fields) through battery_state_pub's rules."""
    message = SimpleNamespace(battery=SimpleNamespace(**record.battery_fields()), **record.sim_fields())
    state = SimpleNamespace(percentage=record.percentage, power_supply_status=record.power_supply_status,
                            sensor_dropout=False, message=lambda: message)
    rules = StatusRules(3.0, 0.2, 0.05, 0.05, _Log(), 'the battery', 'the battery')
    rules.take(state)
    published = rules.to_publish()
    return published, message.battery


def test_by_default_battery_status_has_the_packages_conventions():
    record = record_of(None)
    published, sent = published_battery_fields(record)
    assert published is sent and vars(published) == record.battery_fields()
    record = record_of({'invert_current_sign': False, 'percentage_scale': 1})
    assert vars(published_battery_fields(record)[0]) == record.battery_fields()


@pytest.mark.parametrize('mode', [Mode.DISCHARGE, Mode.CHARGE])
def test_an_inverted_current_sign_and_0_100_percentages_on_battery_status_only(mode):
    plain = record_of(None, mode).battery_fields()
    record = record_of({'invert_current_sign': True, 'percentage_scale': 100}, mode)
    published = vars(published_battery_fields(record)[0])
    assert published['current'] == -plain['current'] != 0.0
    assert published['percentage'] == pytest.approx(100.0 * plain['percentage']) == pytest.approx(80.0, abs=0.1)
    assert {k: v for k, v in published.items() if k not in ('current', 'percentage')} == \
        {k: v for k, v in plain.items() if k not in ('current', 'percentage')}
    assert record.battery_fields() == plain, 'the record itself (battery_simulator/state) keeps its conventions'
    assert record.percentage == pytest.approx(0.8, abs=0.001), 'low/critical and feedback read the record'


def test_an_inverted_zero_current_is_zero_not_minus_zero():
    battery = Battery(replace(preset('lg_hg2_3s1p'), conventions={'invert_current_sign': True}),
                      initial_percentage=80.0, clock=Clock())
    battery.follow_mode_value(None)   # unset: the level holds, no current
    current = published_battery_fields(battery.update().record)[0].current
    assert current == 0.0 and math.copysign(1.0, current) == 1.0


def test_conventions_from_yaml(tmp_path):
    path = tmp_path / 'robot.yaml'
    path.write_text('preset: lg_hg2_3s1p\nconventions: {invert_current_sign: true, percentage_scale: 100}\n'
                    'charger_holds_full: false\n')
    params = load_yaml(path)
    assert params.conventions == {'invert_current_sign': True, 'percentage_scale': 100}
    assert params.charger_holds_full is False


@pytest.mark.parametrize('values, message', [
    ({'conventions': {'percentage_scale': 10}}, 'conventions.percentage_scale = 10 is invalid: must be 1 or 100'),
    ({'conventions': {'percentage_scale': True}}, 'conventions.percentage_scale = True is invalid: must be 1 or 100'),
    ({'conventions': {'invert_current_sign': 1}},
     'conventions.invert_current_sign = 1 is invalid: must be false or true'),
    ({'conventions': {'invert_sign': True}}, 'conventions = {\'invert_sign\': True} is invalid: must be a mapping '
                                             'of invert_current_sign, percentage_scale'),
    ({'conventions': [1]}, 'conventions = [1] is invalid: must be a mapping of invert_current_sign, percentage_scale'),
    ({'charger_holds_full': 'yes'}, 'charger_holds_full = \'yes\' is invalid: must be true or false'),
])
def test_bad_conventions_and_charger_keys_are_one_line_naming_the_key(values, message):
    with pytest.raises(ParameterError) as error:
        from_mapping(values, origin='robot.yaml')
    assert str(error.value) == 'robot.yaml: parameter ' + message


def test_apply_conventions_on_a_message_s_values():
    from battery_simulator.core.battery_record import apply_conventions
    assert apply_conventions(-1.5, 0.8, None) == (-1.5, 0.8)
    assert apply_conventions(-1.5, 0.8, {'invert_current_sign': True}) == (1.5, 0.8)
    assert apply_conventions(2.0, 0.25, {'percentage_scale': 100}) == (2.0, 25.0)
    current, _ = apply_conventions(0.0, 1.0, {'invert_current_sign': True})
    assert math.copysign(1.0, current) == 1.0
