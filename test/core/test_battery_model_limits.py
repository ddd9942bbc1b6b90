"""Physical limits that act within a step, the test controls, resume, and the
ROS-free helpers of the nodes (time base, level alarm, dock contact, base kinematics)."""
import math
from dataclasses import replace

import pytest

from battery_simulator.core.battery_model import BatteryModel
from battery_simulator.core.battery_states import CutOff, Health, Mode, Status
from battery_simulator.core.config_files import preset
from battery_simulator.core.level_alarm import LevelAlarm
from battery_simulator.core.parameter_rules import ParameterError
from battery_simulator.core.time_base import TimeBase

CELL = preset('lg_hg2_cell')
PACK = preset('lg_hg2_3s1p')


def held(params, dt_s, total_s, soc=0.8, **demand):
    model = BatteryModel(params, state_of_charge=soc, mode=Mode.IDLE)
    for _ in range(int(round(total_s / dt_s))):
        model.step(dt_s, **demand)
    return model


@pytest.mark.parametrize('dt_s', [0.01, 0.1, 1.0, 10.0])
def test_an_undeliverable_power_is_cut_off_at_once_at_any_step(dt_s):
    model = held(PACK, dt_s, 10.0, power_w=-10000.0)
    assert model.status is Status.EMPTY and model.cut_off is CutOff.POWER_LIMIT
    assert model.current_a == 0.0 and model.state_of_charge == 0.8, 'nothing was drawn'
    assert model.temperature_c == pytest.approx(PACK.ambient_temperature_c)


@pytest.mark.parametrize('dt_s', [0.1, 1.0, 10.0])
def test_over_current_trips_at_once_and_clears_when_the_load_drops(dt_s):
    model = held(PACK, dt_s, 10.0, current_a=-1000.0)
    assert model.status is Status.EMPTY and model.cut_off is CutOff.OVER_CURRENT
    assert model.voltage_v > 11.0 and model.temperature_c < 30.0, 'no 1000 A ever flowed'
    model.step(dt_s, current_a=-2.0)
    assert model.status is Status.DISCHARGING and model.current_a == pytest.approx(-2.0)


def test_a_charge_current_above_the_datasheet_cuts_the_charger_off():
    model = held(CELL, 1.0, 5.0, soc=0.5, current_a=50.0)
    assert model.status is Status.NOT_CHARGING and model.cut_off is CutOff.OVER_CURRENT
    assert model.state_of_charge == 0.5


def test_a_deliverable_power_draws_p_over_v():
    model = held(PACK, 1.0, 1.0, power_w=-100.0)
    assert model.status is Status.DISCHARGING
    assert model.current_a * model.voltage_v == pytest.approx(-100.0, rel=1e-3)


def hot_run(dt_s):
    # arrhenius 0: no temperature-resistance coupling, whose first-order error is not the point here
    params = replace(CELL, cell_heat_transfer_w_per_k=0.01, cell_heat_capacity_j_per_k=20.0,
                     protection_temperature_c=40.0, overheat_temperature_c=35.0, arrhenius_temperature_k=0.0)
    model = BatteryModel(params, state_of_charge=1.0, mode=Mode.IDLE)
    elapsed = 0.0
    while model.status is not Status.EMPTY and elapsed < 2000.0:
        model.step(dt_s, current_a=-15.0)
        elapsed += dt_s
    return model


def test_over_temperature_cuts_off_within_the_step_at_any_step_size():
    fine, coarse = hot_run(0.1), hot_run(50.0)
    for model in (fine, coarse):
        assert model.status is Status.EMPTY and model.cut_off is CutOff.OVER_TEMPERATURE
        assert model.temperature_c == pytest.approx(40.0, abs=0.01)
    assert coarse.state_of_charge == pytest.approx(fine.state_of_charge, abs=0.002)


def test_a_hot_pack_reconnects_only_after_cooling_below_the_hysteresis():
    model = hot_run(1.0)
    model.step(1.0, current_a=-1.0)
    assert model.status is Status.EMPTY, 'still hot'
    model.step(3600.0, current_a=0.0)
    model.step(1.0, current_a=-1.0)
    assert model.status is Status.DISCHARGING


def test_rc_update_is_exact_for_a_short_time_constant_and_a_long_step():
    params = replace(CELL, tau1_s=30.0, arrhenius_temperature_k=0.0, r_fast_ohm=0.0, resistance_soc=(),
                     r0_soc_factor=(), r1_soc_factor=(), r_fast_soc_factor=())   # isolate the RC pair
    fine = held(params, 0.1, 100.0, current_a=-3.0)
    coarse = held(params, 100.0, 100.0, current_a=-3.0)
    assert coarse.voltage_v == pytest.approx(fine.voltage_v, abs=1e-4)
    assert coarse.rc_voltage_v < -0.9 * 3.0 * params.r1_ohm, 'the RC pair remembers the current'
    fine_heat = held(params, 0.1, 600.0, current_a=-6.0)
    coarse_heat = held(params, 600.0, 600.0, current_a=-6.0)
    assert coarse_heat.temperature_c == pytest.approx(fine_heat.temperature_c, abs=0.05)


def test_c20_termination_is_per_pack_for_a_parallel_pack():
    params = replace(CELL, cells_series=2, cells_parallel=3, charge_current_a=4.5, termination_current_a=None)
    assert params.pack_termination_current_a == pytest.approx(3 * CELL.cell_capacity_ah / 20)
    model = BatteryModel(params, state_of_charge=0.95, mode=Mode.CHARGE)
    currents = []
    while model.status is Status.CHARGING:
        model.step(5.0)
        currents.append(model.current_a)
    assert currents[-2] > params.pack_termination_current_a > 0.9 * currents[-2] * 0.5


def test_every_state_is_consistent_from_the_first_snapshot():
    for mode, sign in ((Mode.DISCHARGE, -1), (Mode.CHARGE, 1)):
        snapshot = BatteryModel(PACK, state_of_charge=0.5, mode=mode).snapshot()
        assert math.copysign(1, snapshot.current_a) == sign and snapshot.current_a != 0.0, snapshot
    model = BatteryModel(PACK, state_of_charge=0.5, mode=Mode.DISCHARGE)
    model.set_mode(Mode.CHARGE)
    assert model.status is Status.CHARGING and model.current_a > 0


@pytest.mark.parametrize('name, value, allowed', [
    ('load_current_a', 1000.0, 'at most 20 A'),
    ('cells_series', 1000000, 'a whole number in [1, 200]'),
    ('charge_current_a', 10.0, 'at most 4 A'),
    ('load_power_w', 1e6, 'at most'),
    ('protection_temperature_c', 500.0, '(0, 150]'),
    ('overheat_temperature_c', 80.0, 'at most protection_temperature_c'),
    ('drive_power_w_per_mps', -1.0, 'in [0, 10000]'),
    ('cmd_vel_timeout_s', 0.0, '> 0'),
])
def test_absurd_configs_are_rejected_with_one_line(name, value, allowed):
    with pytest.raises(ParameterError) as error:
        replace(PACK, **{name: value})
    assert name in str(error.value) and allowed in str(error.value), error.value
    assert '\n' not in str(error.value)


def test_set_state_sets_and_refuses_without_changing_anything():
    model = BatteryModel(PACK, state_of_charge=0.9, mode=Mode.DISCHARGE)
    model.set_state(state_of_charge=0.15, temperature_c=40.0, state_of_health=0.8)
    assert (model.state_of_charge, model.temperature_c, model.state_of_health) == (0.15, 40.0, 0.8)
    assert model.capacity_ah == pytest.approx(0.8 * PACK.design_capacity_ah)
    for bad in (dict(state_of_charge=1.5), dict(temperature_c=math.nan), dict(state_of_health=0.0),
                dict(state_of_charge=0.5, state_of_health=2.0)):
        with pytest.raises(ValueError):
            model.set_state(**bad)
        assert (model.state_of_charge, model.temperature_c, model.state_of_health) == (0.15, 40.0, 0.8), bad
    model.set_state(state_of_charge=0.0)
    assert model.status is Status.EMPTY, 'an empty pack cuts its load off at once'


def test_export_and_restore_resume_the_same_pack():
    model = BatteryModel(PACK, state_of_charge=1.0, mode=Mode.DISCHARGE)
    model.step(3000.0)
    resumed = BatteryModel(PACK, state_of_charge=1.0, mode=Mode.DISCHARGE)
    resumed.restore_state(model.export_state())
    assert resumed.snapshot() == model.snapshot()
    with pytest.raises(ValueError):
        resumed.restore_state({'state_of_charge': 0.5})
    with pytest.raises(ValueError):
        resumed.restore_state(dict(model.export_state(), temperature_c=math.inf))


def test_charger_fault_keeps_the_level_and_reports_not_charging():
    model = BatteryModel(PACK, state_of_charge=0.4, mode=Mode.CHARGE)
    model.set_charger_fault(True)
    model.step(600.0)
    assert model.status is Status.NOT_CHARGING and model.state_of_charge == 0.4 and model.current_a == 0.0
    model.set_charger_fault(False)
    model.step(60.0)
    assert model.status is Status.CHARGING and model.state_of_charge > 0.4


def test_time_remaining_follows_the_present_current():
    model = BatteryModel(PACK, state_of_charge=0.5, mode=Mode.DISCHARGE)
    expected = 0.5 * PACK.cell_capacity_ah * 3600.0 / PACK.load_current_a
    assert model.time_remaining_s == pytest.approx(expected, rel=1e-6)
    model.set_mode(Mode.IDLE)
    assert model.time_remaining_s is None


def test_cold_and_overheat_health():
    model = BatteryModel(PACK, state_of_charge=0.5, mode=Mode.IDLE)
    model.set_state(temperature_c=PACK.cold_temperature_c - 1.0)
    assert model.health is Health.COLD
    model.set_state(temperature_c=PACK.overheat_temperature_c + 1.0)
    assert model.health is Health.OVERHEAT


# -- helpers of the nodes ---------------------------------------------------------

def test_time_base_ignores_the_first_reading_and_backward_jumps():
    base = TimeBase(1.0, zero_is_unset=True)
    assert base.elapsed(0.0) == 0.0, 'no clock yet'
    assert base.elapsed(1.7e9) == 0.0, 'the first /clock is a starting point'
    assert base.elapsed(1.7e9 + 2.0) == pytest.approx(2.0)
    assert base.elapsed(5.0) == 0.0 and base.restarts == 1, 'a jump back drains nothing'
    assert base.elapsed(6.5) == pytest.approx(1.5)
    scaled = TimeBase(22.0)
    scaled.elapsed(100.0)
    assert scaled.elapsed(101.0) == pytest.approx(22.0)


def test_time_base_pending_tells_the_next_elapsed_without_taking_the_reading():
    base = TimeBase(22.0, zero_is_unset=True)
    assert base.pending(0.0) == 0.0 and base.pending(5.0) == 0.0, 'no reading yet'
    base.elapsed(100.0)
    assert base.pending(101.0) == pytest.approx(22.0)
    assert base.pending(101.0) == pytest.approx(22.0), 'not taken'
    assert base.pending(99.0) == 0.0 and base.restarts == 0, 'a jump back: nothing, and no restart'
    assert base.elapsed(101.0) == pytest.approx(22.0)


def test_level_alarm_gives_one_event_for_a_dithering_level():
    alarm = LevelAlarm(0.20, 0.05)
    events = [alarm.update(level) for level in [0.25, 0.21, 0.199, 0.205, 0.195, 0.21, 0.19, 0.24, 0.2]]
    assert events.count(True) == 1 and alarm.active
    assert alarm.update(0.251) and not alarm.active
    with pytest.raises(ValueError):
        LevelAlarm(1.5, 0.05)
