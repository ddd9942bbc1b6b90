"""The battery model: exact updates, bounds, conservation, CC-CV, cut-off, heat, ageing."""
import math
from dataclasses import replace

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from battery_simulator.core.battery_model import BatteryModel
from battery_simulator.core.battery_states import Health, Mode, Status
from battery_simulator.core.cell_tables import OcvCurve
from battery_simulator.core.config_files import preset
from battery_simulator.core.measured_data import time_to_full

CELL = preset('lg_hg2_cell')
PACK = preset('lg_hg2_3s1p')


def run_profile(params, profile, dt_s, soc=0.9):
    """Step through [(duration_s, current_a)] at a fixed step size."""
    model = BatteryModel(params, state_of_charge=soc, mode=Mode.IDLE)
    for duration_s, current_a in profile:
        steps = int(round(duration_s / dt_s))
        for _ in range(steps):
            model.step(dt_s, current_a=current_a)
    return model


# A 2 h mission: drive, idle, climb, partial charge at the dock, drive again.
MISSION = [(1800, -1.5), (600, -0.3), (900, -4.0), (1200, 1.0), (1500, -2.0), (1200, 0.0)]


def test_two_hour_profile_does_not_depend_on_the_step_size():
    fine = run_profile(PACK, MISSION, 0.1)
    coarse = run_profile(PACK, MISSION, 10.0)
    assert abs(fine.state_of_charge - coarse.state_of_charge) <= 0.001, \
        'SOC %.5f vs %.5f' % (fine.state_of_charge, coarse.state_of_charge)
    assert abs(fine.voltage_v - coarse.voltage_v) <= 0.005, \
        'voltage %.4f vs %.4f' % (fine.voltage_v, coarse.voltage_v)


@settings(max_examples=30, deadline=None)
@given(st.lists(st.tuples(st.integers(1, 30).map(lambda k: 20.0 * k), st.floats(-6.0, 3.0)),
                min_size=1, max_size=6),
       st.sampled_from([0.5, 2.0, 5.0, 20.0]))
def test_any_profile_gives_the_same_result_at_any_step(profile, dt_s):
    reference = run_profile(CELL, profile, 1.0, soc=0.6)
    other = run_profile(CELL, profile, dt_s, soc=0.6)
    if reference.status is Status.EMPTY or other.status is Status.EMPTY:
        return  # where the cut-off falls within a step depends on the step
    assert abs(reference.state_of_charge - other.state_of_charge) <= 0.001
    assert abs(reference.voltage_v - other.voltage_v) <= 0.005


@settings(max_examples=50, deadline=None)
@given(st.lists(st.tuples(st.floats(0.1, 3600.0), st.floats(-50.0, 50.0)), min_size=1, max_size=8),
       st.floats(0.0, 1.0))
def test_state_of_charge_stays_within_bounds(profile, soc):
    model = BatteryModel(PACK, state_of_charge=soc, mode=Mode.IDLE)
    for duration_s, current_a in profile:
        model.step(duration_s, current_a=current_a)
        assert 0.0 <= model.state_of_charge <= 1.0
        assert model.voltage_v > 0.0
        assert math.isfinite(model.temperature_c)


def test_charge_in_equals_charge_out_times_efficiency():
    params = replace(CELL, coulombic_efficiency=0.95, capacity_fade_per_cycle=0.0)
    model = BatteryModel(params, state_of_charge=0.5, mode=Mode.IDLE)
    model.step(1800.0, current_a=1.0)   # 0.5 Ah in, 0.475 Ah stored
    model.step(1710.0, current_a=-1.0)  # 0.475 Ah out
    assert model.state_of_charge == pytest.approx(0.5, abs=1e-9)


def test_discharge_counts_coulombs():
    model = BatteryModel(CELL, state_of_charge=1.0, mode=Mode.IDLE)
    model.step(3600.0, current_a=-1.0)
    assert model.state_of_charge == pytest.approx(1.0 - 1.0 / CELL.cell_capacity_ah, rel=1e-6)


def test_cc_cv_charge_tapers_and_ends_full_at_its_termination_current():
    """The LG HG2 charge ends at 50 mA (the measured charges' end, from which the capacity was measured),
    and there the state of charge is 1 on its own (issue 40: before, it stepped from 0.989 to 1)."""
    model = BatteryModel(CELL, state_of_charge=0.1, mode=Mode.CHARGE)
    currents, voltages = [], []
    while model.status is Status.CHARGING:
        soc = model.state_of_charge
        model.step(10.0)
        currents.append(model.current_a)
        voltages.append(model.voltage_v)
    assert model.status is Status.FULL and model.state_of_charge == pytest.approx(1.0, abs=1e-4)
    assert model.state_of_charge - soc <= 0.999 * 0.06 * 10.0 / (CELL.cell_capacity_ah * 3600.0), \
        'the last step moved what its current carried, no more (no step to 100 %)'
    assert currents[0] == pytest.approx(CELL.charge_current_a), 'starts at constant current'
    assert max(voltages) <= CELL.cell_charge_voltage_v + 0.001, 'never above the CV voltage (1 mV)'
    assert model.cell_current_a == 0.0, 'the charge ended: the cells take nothing'
    assert currents[-1] == CELL.load_current_a, 'held full: the charger carries the robot\'s load (Part 7)'
    tapering = [c for c in currents[:-1] if c < CELL.charge_current_a - 1e-9]
    assert tapering and tapering == sorted(tapering, reverse=True), 'CV current falls monotonically'
    termination = CELL.pack_termination_current_a
    assert 0.9 * termination < tapering[-1] < 1.5 * termination, 'ends at the termination current'
    assert CELL.pack_termination_current_a == 0.05
    full = model.state_of_charge
    model.step(100.0)
    assert model.status is Status.FULL and model.state_of_charge == full and model.cell_current_a == 0.0, \
        'held full: nothing into the cells'


def test_charge_goal_at_full_is_full_at_once():
    assert BatteryModel(PACK, state_of_charge=1.0, mode=Mode.CHARGE).status is Status.FULL


def test_discharge_stops_at_cut_off_and_stays_empty():
    model = BatteryModel(PACK, state_of_charge=0.2, mode=Mode.DISCHARGE)
    while model.status is Status.DISCHARGING:
        previous_voltage = model.voltage_v
        model.step(5.0)
    assert model.status is Status.EMPTY
    cut_off_v = PACK.cell_cutoff_voltage_v * PACK.cells_series
    assert previous_voltage > cut_off_v
    assert model.voltage_v >= cut_off_v, 'the load is cut at the cut-off voltage, not past it'
    assert 0.0 <= model.state_of_charge < 0.02
    model.step(3600.0)
    assert model.status is Status.EMPTY and model.current_a == 0.0, 'load stays disconnected'
    model.set_mode(Mode.CHARGE)
    assert model.status is Status.CHARGING


def test_discharge_never_goes_below_zero():
    model = BatteryModel(replace(CELL, cell_cutoff_voltage_v=2.8), state_of_charge=0.001, mode=Mode.DISCHARGE)
    model.step(3600.0, current_a=-10.0)
    assert 0.0 <= model.state_of_charge <= 0.001 and model.status is Status.EMPTY
    assert model.voltage_v >= 2.8, 'disconnected at the cut-off, not below it'


def test_idle_holds_the_level():
    model = BatteryModel(PACK, state_of_charge=0.42, mode=Mode.IDLE)
    model.step(36000.0)
    assert model.state_of_charge == 0.42 and model.status is Status.NOT_CHARGING


def test_constant_power_load_draws_more_current_as_voltage_falls():
    params = replace(PACK, load_current_a=0.0, load_power_w=20.0)
    model = BatteryModel(params, state_of_charge=1.0, mode=Mode.DISCHARGE)
    model.step(1.0)
    high = -model.current_a
    assert high == pytest.approx(20.0 / model.voltage_v, rel=0.02)
    model = BatteryModel(params, state_of_charge=0.15, mode=Mode.DISCHARGE)
    model.step(1.0)
    assert -model.current_a > high


def test_extra_load_terms_add_to_the_base_load():
    model = BatteryModel(PACK, state_of_charge=0.8, mode=Mode.DISCHARGE)
    model.set_extra_load('motion', current_a=2.0)
    model.step(1.0)
    assert model.current_a == pytest.approx(-(PACK.load_current_a + 2.0))
    model.set_extra_load('motion')
    model.step(1.0)
    assert model.current_a == pytest.approx(-PACK.load_current_a)


def test_current_heats_the_cell_and_rest_cools_it():
    model = BatteryModel(CELL, state_of_charge=1.0, mode=Mode.IDLE)
    model.step(600.0, current_a=-6.0)
    hot = model.temperature_c
    assert hot > CELL.ambient_temperature_c + 0.5
    model.step(600.0, current_a=0.0)
    assert CELL.ambient_temperature_c < model.temperature_c < hot


def test_cold_raises_resistance_and_reports_cold():
    warm = BatteryModel(CELL, state_of_charge=0.5, mode=Mode.IDLE)
    cold = BatteryModel(replace(CELL, ambient_temperature_c=-10.0), state_of_charge=0.5, mode=Mode.IDLE)
    warm.step(1.0, current_a=-3.0)
    cold.step(1.0, current_a=-3.0)
    assert cold.voltage_v < warm.voltage_v - 0.05, 'Arrhenius: more sag in the cold'
    assert cold.health is Health.COLD and warm.health is Health.GOOD


def test_overheat_is_reported():
    model = BatteryModel(replace(CELL, ambient_temperature_c=70.0), state_of_charge=0.5)
    assert model.health is Health.OVERHEAT


def test_ageing_fades_capacity_per_equivalent_full_cycle():
    params = replace(CELL, capacity_fade_per_cycle=0.001, initial_cycle_count=100.0)
    model = BatteryModel(params, state_of_charge=1.0, mode=Mode.IDLE)
    assert model.state_of_health == pytest.approx(0.9)
    assert model.snapshot().capacity_ah == pytest.approx(0.9 * CELL.cell_capacity_ah)
    assert model.snapshot().design_capacity_ah == pytest.approx(CELL.cell_capacity_ah)
    model.step(3600.0 * CELL.cell_capacity_ah / 4.0, current_a=-2.0)  # half the design capacity out
    assert model.cycle_count == pytest.approx(100.5, rel=1e-6)
    assert model.state_of_health == pytest.approx(1.0 - 0.001 * 100.5)


def test_pack_scales_cells():
    cell = BatteryModel(CELL, state_of_charge=0.7, mode=Mode.IDLE)
    pack = BatteryModel(replace(CELL, cells_series=4, cells_parallel=2), state_of_charge=0.7, mode=Mode.IDLE)
    cell.step(60.0, current_a=-1.0)
    pack.step(60.0, current_a=-2.0)
    assert pack.voltage_v == pytest.approx(4 * cell.voltage_v)
    assert pack.snapshot().capacity_ah == pytest.approx(2 * cell.snapshot().capacity_ah)


def test_ocv_curve_inverts():
    curve = OcvCurve(CELL.ocv_soc, CELL.ocv_voltage_v)
    for soc in (0.0, 0.03, 0.5, 0.91, 1.0):
        assert curve.soc(curve.voltage(soc)) == pytest.approx(soc, abs=1e-9)


def test_default_pack_discharges_and_charges_in_robot_time():
    """Known numbers of the default pack (documented in the README)."""
    model = BatteryModel(PACK, state_of_charge=1.0, mode=Mode.DISCHARGE)
    elapsed = 0
    while model.status is not Status.EMPTY:
        model.step(10.0)
        elapsed += 10
    assert 6000 <= elapsed <= 7000, '1.5 A from 2.78 Ah: about 1.8 h, got %d s' % elapsed
    # 1.5 A CC, then CV to 50 mA (the LG HG2's end of charge): 2.2 h (2.0 h when it ended at C/20)
    assert 7000 <= time_to_full(model) <= 8500
