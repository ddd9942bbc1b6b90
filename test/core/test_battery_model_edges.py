"""The battery model at its edges: boundaries, messages, protection paths and known answers."""
import math
from dataclasses import replace

import pytest

from battery_simulator.core.battery_model import MIN_STATE_OF_HEALTH, BatteryModel
from battery_simulator.core.battery_parameters import BatteryParameters
from battery_simulator.core.battery_states import CutOff, Mode, Status
from battery_simulator.core.cell_tables import OcvCurve
from battery_simulator.core.config_files import preset

#: the default cell with temperature-independent resistances (linear OCV 2.8..4.2 V)
PLAIN = replace(BatteryParameters(), arrhenius_temperature_k=0.0)


def error_of(call, *args, **kwargs):
    with pytest.raises(ValueError) as error:
        call(*args, **kwargs)
    return str(error.value)


# -- OCV curve --------------------------------------------------------------

def test_ocv_curve_clamps_outside_the_table_and_inverts_per_segment():
    curve = OcvCurve((0.0, 0.5, 1.0), (3.0, 4.0, 4.1))
    assert (curve.voltage(1.5), curve.voltage(-0.5)) == (4.1, 3.0)
    assert curve.soc(3.5) == pytest.approx(0.25) and curve.soc(4.05) == pytest.approx(0.75)
    assert (curve.soc(5.0), curve.soc(2.0)) == (1.0, 0.0)


# -- construction and inputs --------------------------------------------------

def test_defaults():
    model = BatteryModel()
    snapshot = model.snapshot()
    assert model.params == BatteryParameters() and model.state_of_charge == 1.0
    assert snapshot.mode is Mode.DISCHARGE and snapshot.charger_fault is False
    model.set_charger_fault(True)
    assert model.snapshot().charger_fault is True


def test_fractions_are_checked_with_one_line():
    assert error_of(BatteryModel, PLAIN, 1.5) == 'state_of_charge = 1.5 is invalid: must be in [0, 1]'
    model = BatteryModel(PLAIN)
    assert error_of(model.set_state, state_of_charge=True) == 'state_of_charge = True is invalid: must be in [0, 1]'
    assert error_of(model.set_state, state_of_health=1.5) == 'state_of_health = 1.5 is invalid: must be in [0, 1]'
    assert error_of(model.set_state, state_of_health=0.0) == 'state_of_health = 0.0 is invalid: must be in [0.01, 1]'
    # 1e-20 was accepted: ageing then took it to exactly 0 and a division by zero killed the server's worker
    assert error_of(model.set_state, state_of_health=1e-20) == \
        'state_of_health = 1e-20 is invalid: must be in [0.01, 1]'


def test_ageing_never_takes_the_capacity_to_zero():
    model = BatteryModel(PLAIN, state_of_charge=1.0)
    model.set_state(state_of_health=MIN_STATE_OF_HEALTH)
    model.params = replace(PLAIN, capacity_fade_per_cycle=0.009)
    for _ in range(200):   # far more discharge than the pack holds: the floor holds, nothing divides by zero
        model.step(3600.0, current_a=-PLAIN.cell_max_discharge_current_a)
        model.step(3600.0, current_a=PLAIN.cell_max_charge_current_a)
    assert model.state_of_health == MIN_STATE_OF_HEALTH and model.capacity_ah > 0.0
    assert 0.0 <= model.snapshot().percentage <= 100.0


@pytest.mark.parametrize('temperature_c', [-60.5, 150.5, float('nan'), 'hot'])
def test_set_temperature_outside_its_range_is_refused(temperature_c):
    message = error_of(BatteryModel(PLAIN).set_state, temperature_c=temperature_c)
    assert message == 'temperature_c = %r is invalid: must be in [-60, 150] degC' % (temperature_c,)


@pytest.mark.parametrize('temperature_c', [-60.0, 150.0])
def test_set_temperature_at_its_bounds_is_taken(temperature_c):
    model = BatteryModel(PLAIN, mode=Mode.IDLE)
    model.set_state(temperature_c=temperature_c)
    assert model.temperature_c == temperature_c


SAVED = {'state_of_charge': 0.5, 'rc_voltage_v': 0.0, 'fast_rc_voltage_v': 0.0, 'hysteresis': -1.0,
         'temperature_c': 25.0, 'discharged_ah': 0.0, 'state_of_health': 1.0}


@pytest.mark.parametrize('changes', [{'discharged_ah': -0.001}, {'rc_voltage_v': 1.5}, {'rc_voltage_v': -1.5},
                                     {'fast_rc_voltage_v': 1.5}, {'hysteresis': 1.01}, {'hysteresis': -1.01},
                                     {'discharged_ah': float('nan')}, {'state_of_charge': float('inf')}])
def test_restore_refuses_values_out_of_range(changes):
    saved = dict(SAVED, **changes)
    assert error_of(BatteryModel(PLAIN).restore_state, saved) == (
        'saved state %r is invalid: values out of range' % (saved,))


def test_restore_refuses_other_keys_and_names_the_right_ones():
    saved = {'state_of_charge': 0.5}
    assert error_of(BatteryModel(PLAIN).restore_state, saved) == (
        "saved state {'state_of_charge': 0.5} is invalid: must have exactly discharged_ah, fast_rc_voltage_v, "
        "hysteresis, rc_voltage_v, state_of_charge, state_of_health, temperature_c "
        "(fast_rc_voltage_v, hysteresis may be missing)")


@pytest.mark.parametrize('changes', [{'discharged_ah': 0.0}, {'discharged_ah': 0.5}, {'rc_voltage_v': 1.0},
                                     {'rc_voltage_v': -1.0}, {'fast_rc_voltage_v': -1.0}, {'hysteresis': 1.0}])
def test_restore_takes_values_on_their_bounds(changes):
    model = BatteryModel(PLAIN, mode=Mode.IDLE)
    model.restore_state(dict(SAVED, **changes))
    assert model.export_state() == dict(SAVED, **changes)


def test_controls_do_not_move_time():
    model = BatteryModel(PLAIN, state_of_charge=0.5)
    model.step(60.0)
    before = model.export_state()
    model.set_mode(Mode.CHARGE)
    model.set_charger_fault(True)
    model.set_extra_load('never_added')   # removing a load that is not there is fine
    assert model.export_state() == before


def test_a_new_level_starts_from_rest():
    model = BatteryModel(PLAIN, state_of_charge=0.9)
    model.step(600.0)
    model.set_mode(Mode.IDLE)
    model.set_state(state_of_charge=0.5)
    assert model.rc_voltage_v == 0.0 and model.voltage_v == 3.5


# -- statuses -------------------------------------------------------------------

def test_zero_current_is_not_charging_but_full_stays_full():
    model = BatteryModel(PLAIN, state_of_charge=0.5)
    model.step(1.0, current_a=0.0)
    assert model.status is Status.NOT_CHARGING
    full = BatteryModel(PLAIN, state_of_charge=1.0, mode=Mode.CHARGE)
    assert full.status is Status.FULL
    full.step(1.0, current_a=0.0)
    assert full.status is Status.FULL


def test_a_full_pack_without_a_charger_or_with_a_failed_one_is_not_charging():
    assert BatteryModel(PLAIN, state_of_charge=1.0, mode=Mode.IDLE).status is Status.NOT_CHARGING
    model = BatteryModel(PLAIN, state_of_charge=1.0, mode=Mode.CHARGE)
    model.set_charger_fault(True)
    assert model.status is Status.NOT_CHARGING


def test_an_empty_pack_charges():
    model = BatteryModel(PLAIN, state_of_charge=0.05)
    model.step(3600.0)
    assert model.status is Status.EMPTY and model.current_a == 0.0
    level = model.state_of_charge
    model.step(600.0)
    assert model.state_of_charge == level and model.current_a == 0.0, 'an empty pack stays empty'
    model.set_mode(Mode.CHARGE)
    assert model.status is Status.CHARGING and model.cut_off is None and model.current_a == 1.5
    flat = BatteryModel(PLAIN, state_of_charge=0.0)
    assert flat.status is Status.EMPTY
    flat.set_mode(Mode.CHARGE)
    assert flat.status is Status.CHARGING and flat.cut_off is None and flat.current_a == 1.5


def test_a_resting_pack_exactly_at_the_cut_off_is_empty():
    # OCV 3.5 V at 50 % equals the cut-off; with no load the terminal voltage is exactly that
    params = replace(PLAIN, ocv_soc=(0.0, 0.5, 1.0), ocv_voltage_v=(3.0, 3.5, 4.0), cell_charge_voltage_v=4.0,
                     cell_cutoff_voltage_v=3.5, load_current_a=0.0)
    model = BatteryModel(params, state_of_charge=0.5, mode=Mode.IDLE)
    assert model.voltage_v == 3.5
    model.set_mode(Mode.DISCHARGE)
    assert (model.status, model.cut_off) == (Status.EMPTY, CutOff.UNDER_VOLTAGE)


def test_zero_charge_is_empty_even_with_polarisation_holding_the_voltage_up():
    model = BatteryModel(replace(PLAIN, load_current_a=0.0))
    model.restore_state(dict(SAVED, state_of_charge=0.0, rc_voltage_v=0.5))
    assert model.voltage_v == pytest.approx(3.3)
    assert (model.status, model.cut_off) == (Status.EMPTY, CutOff.UNDER_VOLTAGE)


# -- charging -------------------------------------------------------------------

def test_a_charge_that_overshoots_full_within_a_step_ends_full():
    # polarised by a heavy discharge, the pack takes the full charge current up to the top
    model = BatteryModel(replace(PLAIN, tau1_s=3000.0), mode=Mode.IDLE)
    model.restore_state(dict(SAVED, state_of_charge=0.999, rc_voltage_v=-0.5))
    model.set_mode(Mode.CHARGE)
    assert model.status is Status.CHARGING and model.current_a == 1.5
    model.step(100.0)
    assert (model.status, model.state_of_charge, model.cell_current_a) == (Status.FULL, 1.0, 0.0)
    assert model.snapshot().percentage == 100.0


def test_cv_steps_end_exactly_at_the_charge_voltage():
    model = BatteryModel(PLAIN, state_of_charge=0.97, mode=Mode.CHARGE)
    cv_steps = 0
    while model.status is Status.CHARGING and cv_steps < 10000:
        model.step(10.0)
        if model.status is Status.CHARGING and model.current_a < 1.5:
            cv_steps += 1
            assert model.cell_voltage_v == pytest.approx(4.2, abs=1e-9)
    assert cv_steps > 10 and model.status is Status.FULL


def test_end_of_taper_moves_no_charge_and_no_voltage_but_its_current_s():
    """Issue 40: the end of the taper no longer steps the SOC to 1 (charge appeared there: 1.1 % a cycle).
    The step that ends it carries no current: the SOC stays, the RC pair relaxes, and the terminal voltage
    is the OCV plus the RC voltage (the current's R0 drop gone)."""
    model = BatteryModel(PLAIN, state_of_charge=0.99, mode=Mode.CHARGE)
    while True:
        before = (model.state_of_charge, model.rc_voltage_v, model.throughput_as)
        model.step(1.0)
        if model.status is Status.FULL:
            break
    soc, rc_voltage, throughput = before
    assert model.state_of_charge == soc and model.throughput_as == throughput
    assert model.rc_voltage_v == pytest.approx(math.exp(-1.0 / PLAIN.tau1_s) * rc_voltage, abs=1e-12)
    assert model.cell_voltage_v == pytest.approx(model.ocv.voltage(soc) + model.rc_voltage_v, abs=1e-12)


def test_a_small_current_below_the_termination_still_charges_in_cc():
    model = BatteryModel(PLAIN, state_of_charge=0.5)
    model.step(10.0, current_a=0.1)   # C/20 = 0.139 A, but the charger gives all that is asked
    assert model.status is Status.CHARGING and model.current_a == pytest.approx(0.1)


def test_charging_does_not_age_the_pack():
    model = BatteryModel(replace(PLAIN, capacity_fade_per_cycle=0.001), state_of_charge=0.2, mode=Mode.IDLE)
    model.step(3600.0, current_a=0.5)
    assert model.cycle_count == 0.0 and model.state_of_health == 1.0
    assert model.state_of_charge == pytest.approx(0.2 + 0.5 * 0.999 / 2.78)


def test_a_positive_power_charges_at_p_over_v():
    model = BatteryModel(PLAIN, state_of_charge=0.5, mode=Mode.IDLE)
    model.step(1.0, power_w=0.5)
    assert model.status is Status.CHARGING and model.current_a == pytest.approx(0.5 / 3.5)


# -- protection -------------------------------------------------------------------

def test_currents_exactly_at_the_datasheet_limits_flow_and_clear_a_trip():
    model = BatteryModel(PLAIN, state_of_charge=0.5)
    model.step(1.0, current_a=4.0)
    assert model.status is Status.CHARGING and model.current_a == 4.0
    model.step(1.0, current_a=4.5)
    assert (model.status, model.cut_off, model.current_a) == (Status.NOT_CHARGING, CutOff.OVER_CURRENT, 0.0)
    model.step(1.0, current_a=4.0)
    assert (model.status, model.cut_off, model.current_a) == (Status.CHARGING, None, 4.0)
    model.step(1.0, current_a=5.0)
    model.step(1.0, current_a=1.0)
    assert (model.status, model.cut_off, model.current_a) == (Status.CHARGING, None, 1.0)
    model.step(1.0, current_a=-20.0)
    assert model.status is Status.DISCHARGING and model.current_a == -20.0
    model.step(1.0, current_a=-25.0)
    assert (model.status, model.cut_off, model.current_a) == (Status.EMPTY, CutOff.OVER_CURRENT, 0.0)
    model.step(1.0, current_a=-20.0)
    assert (model.status, model.cut_off, model.current_a) == (Status.DISCHARGING, None, -20.0)


def test_a_parallel_pack_clears_an_over_current_at_its_own_limit():
    model = BatteryModel(preset('kobuki_4s2p'), state_of_charge=0.8)   # 10 A per cell, 2 in parallel
    model.step(1.0, current_a=-25.0)
    assert model.cut_off is CutOff.OVER_CURRENT
    model.step(1.0, current_a=-15.0)
    assert model.cut_off is None and model.current_a == -15.0


HOT = replace(PLAIN, ambient_temperature_c=90.0, initial_temperature_c=70.0)


def test_a_pack_heating_past_the_protection_while_charging_stops_at_that_moment():
    model = BatteryModel(HOT, state_of_charge=0.5, mode=Mode.CHARGE)
    model.step(3600.0)
    assert (model.status, model.cut_off, model.current_a) == (Status.NOT_CHARGING, CutOff.OVER_TEMPERATURE, 0.0)
    assert model.temperature_c == pytest.approx(75.0, abs=0.01)
    # 70 -> 75 degC towards 91 degC with a 750 s time constant: about 203 s at 1.5 A, not an hour
    assert 0.5 + 1.5 * 195 / 10008 < model.state_of_charge < 0.5 + 1.5 * 210 / 10008
    model.step(1.0, current_a=1.0)
    assert model.status is Status.NOT_CHARGING and model.current_a == 0.0


def test_a_hot_pack_with_nothing_connected_is_not_cut_off():
    model = BatteryModel(HOT, state_of_charge=0.5, mode=Mode.IDLE)
    model.step(3600.0)
    assert model.cut_off is None and model.status is Status.NOT_CHARGING and model.temperature_c > 85.0


def test_the_protection_temperature_itself_trips_the_charger():
    model = BatteryModel(PLAIN, state_of_charge=0.5, mode=Mode.CHARGE)
    model.set_state(temperature_c=75.0)
    assert (model.status, model.cut_off) == (Status.NOT_CHARGING, CutOff.OVER_TEMPERATURE)


def test_over_temperature_holds_through_mode_changes_until_below_the_hysteresis():
    model = BatteryModel(PLAIN, state_of_charge=0.8)
    model.set_state(temperature_c=74.9)
    model.step(60.0, current_a=-15.0)
    assert (model.status, model.cut_off) == (Status.EMPTY, CutOff.OVER_TEMPERATURE)
    model.step(0.0, current_a=1.0)   # a charger plugged in while the protection holds
    assert (model.status, model.current_a) == (Status.NOT_CHARGING, 0.0)
    model.set_mode(Mode.IDLE)
    assert model.status is Status.NOT_CHARGING
    for _ in range(1000):
        if model.temperature_c < 73.0:
            break
        model.step(1.0)
    assert 70.0 < model.temperature_c < 73.0
    model.set_mode(Mode.CHARGE)
    assert (model.status, model.cut_off, model.current_a) == (Status.NOT_CHARGING, CutOff.OVER_TEMPERATURE, 0.0)


# -- loads: known answers -------------------------------------------------------

def terminal_power_identity(model, load_current_a):
    """Power at the terminals beside the constant-current part: (|I| - I_c) x V."""
    return (-model.current_a - load_current_a) * model.voltage_v


@pytest.mark.parametrize('load_power_w', [4.0, 20.0])
def test_a_parallel_pack_delivers_the_power_load_exactly_when_cold_and_polarised(load_power_w):
    params = replace(preset('kobuki_4s2p'), load_current_a=2.0, load_power_w=load_power_w, ambient_temperature_c=0.0)
    model = BatteryModel(params, state_of_charge=0.7)
    model.step(300.0)
    assert model.rc_voltage_v < -0.01 and model.temperature_c < 10.0
    model.step(0.0)
    assert terminal_power_identity(model, 2.0) == pytest.approx(load_power_w, rel=1e-9)


def test_an_extra_power_term_adds_to_the_load():
    model = BatteryModel(PLAIN, state_of_charge=0.8)
    model.set_extra_load('motion', power_w=10.0)
    model.step(0.0)
    assert terminal_power_identity(model, 1.5) == pytest.approx(10.0, rel=1e-9)


def test_a_power_near_the_maximum_is_still_delivered():
    # E = 4.2 V, R0 = 0.02 ohm: at most E^2 / 4 R0 = 220.5 W; 215 W needs about 88 A at 2.44 V
    params = replace(PLAIN, ocv_voltage_v=(2.0, 4.2), cell_cutoff_voltage_v=2.0, cell_max_discharge_current_a=100.0)
    model = BatteryModel(params, state_of_charge=1.0, mode=Mode.IDLE)
    model.step(1e-6, power_w=-215.0)
    assert model.status is Status.DISCHARGING and model.cut_off is None
    assert model.current_a * model.voltage_v == pytest.approx(-215.0, rel=1e-4)
    assert model.current_a == pytest.approx(-88.4, abs=0.1)


def test_a_low_voltage_chemistry_delivers_small_powers():
    params = replace(PLAIN, ocv_voltage_v=(0.9, 1.45), cell_charge_voltage_v=1.45, cell_cutoff_voltage_v=0.9)
    model = BatteryModel(params, state_of_charge=0.05, mode=Mode.IDLE)
    model.step(0.0, power_w=-0.1)
    assert model.status is Status.DISCHARGING
    assert model.current_a * model.voltage_v == pytest.approx(-0.1, rel=1e-9)


def test_long_step_heat_and_polarisation_at_zero_degrees():
    # one step of 100 time constants at 1 A and 0 degC: both resistances scaled by Arrhenius
    params = replace(BatteryParameters(), ambient_temperature_c=0.0)
    model = BatteryModel(params, state_of_charge=0.9, mode=Mode.IDLE)
    scale = math.exp(2800.0 * (1 / 273.15 - 1 / 298.15))
    assert scale == pytest.approx(2.3621, abs=1e-4)
    dt_s = 100 * params.tau1_s
    model.step(dt_s, current_a=-1.0)
    r0, r1 = 0.02 * scale, 0.015 * scale
    assert model.rc_voltage_v == pytest.approx(-r1 * (1 - math.exp(-100)), rel=1e-12)
    v1_mean = -r1 * (1 - params.tau1_s / dt_s)
    heat_w = r0 + v1_mean * -1.0
    thermal = math.exp(-dt_s * 0.06 / 45.0)
    assert model.temperature_c == pytest.approx(heat_w / 0.06 * (1 - thermal), rel=1e-9)


def test_the_rc_share_of_the_heat_counts_within_a_short_step():
    params = replace(PLAIN, tau1_s=0.1, r1_ohm=0.5)
    model = BatteryModel(params, state_of_charge=0.9, mode=Mode.IDLE)
    model.step(1.0, current_a=-2.0)
    v1_settled = -2.0 * 0.5
    v1_mean = v1_settled * (1 - (1 - math.exp(-10)) * 0.1)
    heat_w = 4.0 * 0.02 + -2.0 * v1_mean
    expected = 25.0 + heat_w / 0.06 * (1 - math.exp(-0.06 / 45.0))
    assert model.temperature_c == pytest.approx(expected, abs=1e-12)
    assert model.temperature_c - (25.0 + 0.08 / 0.06 * (1 - math.exp(-0.06 / 45.0))) > 0.03
