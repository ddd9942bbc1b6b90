"""The model snapshot -> sensor_msgs/BatteryState and BatterySimState mapping."""
import math

import pytest

genpy = pytest.importorskip('genpy')

from battery_simulator.core.battery_model import BatteryModel
from battery_simulator.core.battery_states import Mode
from battery_simulator.core.config_files import preset

battery_state = pytest.importorskip('battery_simulator.ros1.messages',
                                    reason='needs the devel space (tools/run_tests.sh)')
BatteryState = battery_state.BatteryState
PACK = preset('lg_hg2_3s1p')


def message(mode, soc=0.5, **changes):
    model = BatteryModel(PACK, state_of_charge=soc, mode=mode)
    for name, value in changes.items():
        setattr(model, name, value)
    return model, battery_state.to_battery_state(model.snapshot(), PACK, frame_id='battery')


def test_discharging_maps_every_field_in_pack_units():
    model, msg = message(Mode.DISCHARGE, soc=0.42)
    assert msg.power_supply_status == BatteryState.POWER_SUPPLY_STATUS_DISCHARGING
    assert msg.current == pytest.approx(-PACK.load_current_a) and msg.current < 0
    assert msg.percentage == pytest.approx(0.42) and 0.0 <= msg.percentage <= 1.0
    assert msg.voltage == pytest.approx(model.voltage_v) and msg.voltage > 0
    assert msg.charge == pytest.approx(0.42 * PACK.design_capacity_ah)
    assert msg.capacity == pytest.approx(PACK.design_capacity_ah)
    assert msg.design_capacity == pytest.approx(PACK.design_capacity_ah)
    assert msg.temperature == pytest.approx(PACK.ambient_temperature_c)
    assert msg.power_supply_health == BatteryState.POWER_SUPPLY_HEALTH_GOOD
    assert msg.power_supply_technology == BatteryState.POWER_SUPPLY_TECHNOLOGY_LION
    assert msg.present is True
    assert len(msg.cell_voltage) == 3 and sum(msg.cell_voltage) == pytest.approx(msg.voltage)
    assert msg.cell_temperature == [msg.temperature] * 3
    assert (msg.location, msg.serial_number, msg.header.frame_id) == ('base', 'SIM-3S1P-0001', 'battery')


def test_charging_full_idle_and_empty():
    _, msg = message(Mode.CHARGE, soc=0.3)
    assert msg.power_supply_status == BatteryState.POWER_SUPPLY_STATUS_CHARGING and msg.current > 0
    _, msg = message(Mode.CHARGE, soc=1.0)
    # on the charger a full pack is held full: the charger carries the base load through it (Part 7)
    assert msg.power_supply_status == BatteryState.POWER_SUPPLY_STATUS_FULL and msg.current == pytest.approx(1.5)
    _, msg = message(Mode.IDLE)
    assert msg.power_supply_status == BatteryState.POWER_SUPPLY_STATUS_NOT_CHARGING and msg.current == 0.0
    _, msg = message(Mode.DISCHARGE, soc=0.0)
    assert msg.power_supply_status == BatteryState.POWER_SUPPLY_STATUS_NOT_CHARGING, 'EMPTY: load cut off'
    assert msg.current == 0.0


def test_health_maps_overheat_and_cold():
    model = BatteryModel(PACK, state_of_charge=0.5, mode=Mode.IDLE)
    model.set_state(temperature_c=70.0)
    msg = battery_state.to_battery_state(model.snapshot(), PACK)
    assert msg.power_supply_health == BatteryState.POWER_SUPPLY_HEALTH_OVERHEAT
    model.set_state(temperature_c=-5.0)
    msg = battery_state.to_battery_state(model.snapshot(), PACK)
    assert msg.power_supply_health == BatteryState.POWER_SUPPLY_HEALTH_COLD


def test_sim_state_carries_what_diagnostics_and_the_gate_need():
    model = BatteryModel(PACK, state_of_charge=0.5, mode=Mode.DISCHARGE)
    state = battery_state.to_sim_state(model.snapshot(), PACK, load_power_w=12.5, faults={'overheat', 'charger_fault'})
    assert state.charging_state == 'Discharging' and state.cut_off == ''
    assert state.time_remaining_s == pytest.approx(model.time_remaining_s)
    assert state.load_power_w == 12.5 and state.active_faults == ['charger_fault', 'overheat']
    assert state.sensor_dropout is False and state.state_of_health == pytest.approx(1.0)
    empty = BatteryModel(PACK, state_of_charge=0.0, mode=Mode.DISCHARGE)
    state = battery_state.to_sim_state(empty.snapshot(), PACK, faults={'sensor_dropout'})
    assert state.charging_state == 'Empty' and state.cut_off == 'cut-off voltage reached'
    assert math.isnan(state.time_remaining_s) and state.sensor_dropout is True
    for mode, soc, text in ((Mode.CHARGE, 0.5, 'Charging'), (Mode.CHARGE, 1.0, 'Full'), (Mode.IDLE, 0.5, 'Not Charging')):
        state = battery_state.to_sim_state(BatteryModel(PACK, state_of_charge=soc, mode=mode).snapshot(), PACK)
        assert state.charging_state == text


def test_stamps_and_counts_pass_through():
    stamp = genpy.Time(1234, 5678)
    model = BatteryModel(PACK, state_of_charge=0.5, mode=Mode.DISCHARGE)
    model.step(1800.0)
    snapshot = model.snapshot()
    assert battery_state.to_battery_state(snapshot, PACK, stamp=stamp).header.stamp == stamp
    state = battery_state.to_sim_state(snapshot, PACK, stamp=stamp)
    assert state.battery.header.stamp == stamp
    assert state.battery.voltage == pytest.approx(snapshot.voltage_v)
    assert state.cycle_count == pytest.approx(0.5 * PACK.load_current_a / PACK.cell_capacity_ah, rel=1e-6)  # 0.5 h at 1.5 A


def test_defaults_are_no_frame_and_no_extra_load():
    snapshot = BatteryModel(PACK, state_of_charge=0.5).snapshot()
    assert battery_state.to_battery_state(snapshot, PACK).header.frame_id == ''
    state = battery_state.to_sim_state(snapshot, PACK)
    assert state.battery.header.frame_id == '' and state.load_power_w == 0.0
