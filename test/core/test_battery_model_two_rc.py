"""The fast RC pair, the resistances by SOC and direction, and the OCV hysteresis (issue 25)."""
import math
from dataclasses import replace

import pytest

from battery_simulator.core.battery_model import BatteryModel
from battery_simulator.core.battery_parameters import BatteryParameters
from battery_simulator.core.battery_states import Mode, Status
from battery_simulator.core.cell_tables import ResistanceTable
from battery_simulator.core.parameter_rules import ParameterError

#: the default cell (linear OCV 2.8..4.2 V) without Arrhenius, with every issue-25 feature on
TWO_RC = replace(BatteryParameters(), arrhenius_temperature_k=0.0, r_fast_ohm=0.01, tau_fast_s=15.0,
                 resistance_soc=(0.0, 0.5, 1.0), r0_soc_factor=(2.0, 1.0, 1.5), r1_soc_factor=(3.0, 1.0, 1.0),
                 r_fast_soc_factor=(1.0, 1.0, 2.0), r0_charge_factor=0.8, r1_charge_factor=1.2,
                 r_fast_charge_factor=0.5, ocv_charge_voltage_v=(2.9, 4.25), hysteresis_ah=0.05)


def test_resistances_follow_the_soc_tables_and_the_direction():
    table = ResistanceTable(TWO_RC)
    assert table.at(0.0, False) == pytest.approx((0.04, 0.045, 0.01))
    assert table.at(0.25, False) == pytest.approx((0.03, 0.03, 0.01))
    assert table.at(1.0, True) == pytest.approx((0.02 * 1.5 * 0.8, 0.015 * 1.2, 0.01 * 2.0 * 0.5))
    assert table.at(1.5, False) == table.at(1.0, False), 'clamped to the table'


def test_both_pairs_follow_their_exact_exponentials():
    params = replace(TWO_RC, ocv_charge_voltage_v=(), resistance_soc=(), r0_soc_factor=(), r1_soc_factor=(),
                     r_fast_soc_factor=())
    model = BatteryModel(params, state_of_charge=0.8, mode=Mode.IDLE)
    model.step(30.0, current_a=-2.0)
    assert model.fast_rc_voltage_v == pytest.approx(-2.0 * 0.01 * (1 - math.exp(-2.0)), rel=1e-12)
    assert model.rc_voltage_v == pytest.approx(-2.0 * 0.015 * (1 - math.exp(-0.5)), rel=1e-12)
    assert model.cell_voltage_v == pytest.approx(
        model.ocv.voltage(model.state_of_charge) + model.rc_voltage_v + model.fast_rc_voltage_v - 2.0 * 0.02,
        abs=1e-12)


def test_hysteresis_moves_exactly_with_the_charge_put_through():
    model = BatteryModel(TWO_RC, state_of_charge=0.5, mode=Mode.IDLE)
    assert model.hysteresis == -1.0 and model.open_circuit_voltage_v == pytest.approx(3.5)
    model.step(60.0, current_a=3.0)   # 0.05 Ah: one hysteresis_ah
    assert model.hysteresis == pytest.approx(1.0 - 2.0 * math.exp(-1.0), rel=1e-12)
    halves = BatteryModel(TWO_RC, state_of_charge=0.5, mode=Mode.IDLE)
    halves.step(30.0, current_a=3.0)
    halves.step(30.0, current_a=3.0)
    assert halves.hysteresis == pytest.approx(model.hysteresis, rel=1e-12)
    model.step(3600.0, current_a=1.0)
    gap = (2.9 - 2.8) + (4.25 - 4.2 - 0.1) * model.state_of_charge
    assert model.open_circuit_voltage_v == pytest.approx(model.ocv.voltage(model.state_of_charge) + gap, abs=1e-9)
    model.step(3600.0, current_a=-1.0)
    assert model.hysteresis == pytest.approx(-1.0, abs=1e-8)   # exp(-20) left


def test_cv_steps_end_exactly_at_the_charge_voltage_with_both_pairs_and_hysteresis():
    model = BatteryModel(TWO_RC, state_of_charge=0.9, mode=Mode.CHARGE)
    cv_steps = 0
    while model.status is Status.CHARGING and cv_steps < 10000:
        model.step(10.0)
        if model.status is Status.CHARGING and model.current_a < 1.5:
            cv_steps += 1
            assert model.cell_voltage_v == pytest.approx(4.2, abs=2e-5)
    assert cv_steps > 10 and model.status is Status.FULL


@pytest.mark.parametrize('dt_s', [0.5, 5.0, 30.0])
def test_a_mission_hardly_depends_on_the_step_size(dt_s):
    def run(step_s):
        model = BatteryModel(TWO_RC, state_of_charge=0.9, mode=Mode.IDLE)
        for duration_s, current_a in ((1800, -1.5), (600, -0.3), (900, -3.0), (1200, 1.0), (600, 0.0)):
            for _ in range(int(round(duration_s / step_s))):
                model.step(step_s, current_a=current_a)
        return model
    fine, coarse = run(0.1), run(dt_s)
    assert coarse.state_of_charge == pytest.approx(fine.state_of_charge, abs=1e-3)
    assert coarse.voltage_v == pytest.approx(fine.voltage_v, abs=3e-3)
    assert coarse.hysteresis == pytest.approx(fine.hysteresis, abs=1e-3)


def test_a_long_step_through_the_resistance_tables_stays_close_to_fine_steps():
    def run(step_s):
        model = BatteryModel(replace(TWO_RC, ocv_charge_voltage_v=()), state_of_charge=0.9, mode=Mode.IDLE)
        for _ in range(int(round(600.0 / step_s))):
            model.step(step_s, current_a=-3.0)
        return model
    fine, coarse = run(0.5), run(600.0)
    assert coarse.state_of_charge == pytest.approx(fine.state_of_charge, abs=1e-5)   # fade per step
    assert coarse.voltage_v == pytest.approx(fine.voltage_v, abs=2e-3)
    assert coarse.temperature_c == pytest.approx(fine.temperature_c, abs=0.05)


def test_the_cut_off_is_found_within_the_step():
    def empty_at(step_s):
        model = BatteryModel(TWO_RC, state_of_charge=0.05, mode=Mode.IDLE)
        while model.status is not Status.EMPTY:
            model.step(step_s, current_a=-3.0)
        return model.state_of_charge
    one_step, fine = empty_at(600.0), empty_at(1.0)
    assert 0.0 < fine < 0.05
    assert one_step == pytest.approx(fine, abs=2e-3), 'the cut-off found within a 600 s step'


def test_the_fast_pair_shares_the_heat():
    with_fast = BatteryModel(replace(TWO_RC, ocv_charge_voltage_v=()), state_of_charge=0.5, mode=Mode.IDLE)
    without = BatteryModel(replace(TWO_RC, ocv_charge_voltage_v=(), r_fast_ohm=0.0), state_of_charge=0.5,
                           mode=Mode.IDLE)
    for model in (with_fast, without):
        model.step(600.0, current_a=-3.0)
    assert with_fast.temperature_c > without.temperature_c


def test_the_new_state_is_saved_and_restored():
    model = BatteryModel(TWO_RC, state_of_charge=0.6, mode=Mode.IDLE)
    model.step(120.0, current_a=2.0)
    saved = model.export_state()
    assert saved['hysteresis'] > -1.0 and saved['fast_rc_voltage_v'] > 0.0
    resumed = BatteryModel(TWO_RC)
    resumed.restore_state(saved)
    assert resumed.export_state() == saved
    assert resumed.voltage_v == pytest.approx(BatteryModel(TWO_RC).voltage_v, abs=1.0)


@pytest.mark.parametrize('changes, name', [
    ({'r_fast_ohm': -0.1}, 'r_fast_ohm'),
    ({'tau_fast_s': 0.0}, 'tau_fast_s'),
    ({'hysteresis_ah': 0.0}, 'hysteresis_ah'),
    ({'r1_charge_factor': 0.0}, 'r1_charge_factor'),
    ({'ocv_charge_voltage_v': (2.9,)}, 'ocv_charge_voltage_v'),
    ({'ocv_charge_voltage_v': (2.7, 4.3)}, 'ocv_charge_voltage_v'),
    ({'ocv_charge_voltage_v': (4.3, 4.25)}, 'ocv_charge_voltage_v'),
    ({'resistance_soc': (0.0, 0.6)}, 'resistance_soc'),
    ({'resistance_soc': (0.0, 1.0), 'r0_soc_factor': (1.0, 1.0, 1.0)}, 'r0_soc_factor'),
    ({'resistance_soc': (0.0, 1.0), 'r1_soc_factor': (1.0, -1.0)}, 'r1_soc_factor'),
    ({'r_fast_soc_factor': (1.0,)}, 'r_fast_soc_factor'),
])
def test_bad_new_values_name_their_key(changes, name):
    with pytest.raises(ParameterError, match='parameter %s = ' % name):
        replace(BatteryParameters(), **changes)
