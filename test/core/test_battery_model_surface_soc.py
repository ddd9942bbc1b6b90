"""The surface state of charge (surface_soc_lag_s, tau_surface_s): the OCV read at the bulk SOC less a
first-order lag of the current (solid diffusion), the charge counted exactly; off by default."""
import math
from dataclasses import replace

import pytest

from battery_simulator.core.battery_model import BatteryModel
from battery_simulator.core.battery_parameters import BatteryParameters
from battery_simulator.core.battery_states import Mode, Status
from battery_simulator.core.config_files import from_mapping
from battery_simulator.core.parameter_rules import ParameterError

#: the default cell (linear OCV 2.8..4.2 V, 2.78 Ah) without Arrhenius or fade, with a 100 s lag of 300 s
PLAIN = replace(BatteryParameters(), arrhenius_temperature_k=0.0, capacity_fade_per_cycle=0.0)
LAGGED = replace(PLAIN, surface_soc_lag_s=100.0, tau_surface_s=300.0)
CAPACITY_AS = 2.78 * 3600.0


def test_the_lag_settles_at_lag_s_seconds_of_the_current_exactly():
    model = BatteryModel(LAGGED, state_of_charge=0.8, mode=Mode.IDLE)
    model.step(150.0, current_a=-2.0)
    settled = 100.0 * 2.0 / CAPACITY_AS   # SOC units: 100 s of a 2 A discharge
    assert model.surface_soc_lag == pytest.approx(settled * (1.0 - math.exp(-0.5)), rel=1e-12)
    model.step(3000.0, current_a=-2.0)   # ten time constants more
    assert model.surface_soc_lag == pytest.approx(settled, rel=1e-4)
    assert model.surface_soc == model.state_of_charge - model.surface_soc_lag
    # the OCV is read at the surface SOC: 1.4 V per unit SOC on this table
    assert model.open_circuit_voltage_v == pytest.approx(2.8 + 1.4 * model.surface_soc, rel=1e-12)
    rest = model.surface_soc_lag
    model.step(300.0, current_a=0.0)   # at rest it relaxes with tau_surface_s
    assert model.surface_soc_lag == pytest.approx(rest * math.exp(-1.0), rel=1e-12)
    model.step(600.0, current_a=1.0)   # charging: the surface above the bulk
    assert model.surface_soc_lag < 0.0 and model.surface_soc > model.state_of_charge


def test_the_bulk_soc_counts_every_coulomb_whatever_the_lag():
    plain = BatteryModel(PLAIN, state_of_charge=0.8, mode=Mode.IDLE)
    lagged = BatteryModel(LAGGED, state_of_charge=0.8, mode=Mode.IDLE)
    for current, seconds in ((-2.0, 700.0), (0.0, 100.0), (-0.5, 50.0), (1.0, 400.0)):
        for model in (plain, lagged):
            model.step(seconds, current_a=current)
    assert lagged.state_of_charge == plain.state_of_charge   # the same coulombs, to the last bit
    efficiency = PLAIN.coulombic_efficiency
    assert lagged.state_of_charge == pytest.approx(
        0.8 + (-2.0 * 700.0 - 0.5 * 50.0 + efficiency * 400.0) / CAPACITY_AS, abs=1e-12)
    assert lagged.throughput_as == plain.throughput_as


def test_a_lagged_cell_cuts_off_earlier_at_a_higher_current():
    """The charge given to the cut-off falls with the current (the surface empties first), by about
    lag_s x the current's difference (the OCV's slope here is gentle: a little less)."""
    def delivered(params, current):
        model = BatteryModel(params, state_of_charge=1.0, mode=Mode.IDLE)
        while model.status is not Status.EMPTY:
            model.step(10.0, current_a=-current)
        return 1.0 - model.state_of_charge
    plain = [delivered(PLAIN, current) for current in (0.5, 2.0)]
    lagged = [delivered(LAGGED, current) for current in (0.5, 2.0)]
    extra_at_high = (plain[1] - lagged[1]) - (plain[0] - lagged[0])
    assert 0.0 < extra_at_high <= 100.0 * 1.5 / CAPACITY_AS


def test_off_by_default_and_a_state_without_it_resumes():
    assert BatteryParameters().surface_soc_lag_s == 0.0
    model = BatteryModel(PLAIN, state_of_charge=0.6, mode=Mode.IDLE)
    model.step(500.0, current_a=-3.0)
    assert model.surface_soc_lag == 0.0 and model.surface_soc == model.state_of_charge
    assert 'surface_soc_lag' not in model.export_state()
    lagged = BatteryModel(LAGGED, state_of_charge=0.6, mode=Mode.IDLE)
    lagged.step(500.0, current_a=-3.0)
    saved = lagged.export_state()
    again = BatteryModel(LAGGED, state_of_charge=0.9, mode=Mode.IDLE)
    again.restore_state(saved)
    assert again.surface_soc_lag == saved['surface_soc_lag'] > 0.0
    older = BatteryModel(LAGGED, state_of_charge=0.9, mode=Mode.IDLE)
    older.restore_state(model.export_state())   # saved before the lag: it resumes settled
    assert older.surface_soc_lag == 0.0 and older.state_of_charge == model.state_of_charge
    with pytest.raises(ValueError):
        again.restore_state(dict(saved, surface_soc_lag=2.0, state_of_charge=0.1))
    assert again.surface_soc_lag == saved['surface_soc_lag'] and again.state_of_charge != 0.1   # nothing changed


def test_cv_ends_at_the_charge_voltage_with_the_lag():
    model = BatteryModel(LAGGED, state_of_charge=0.85, mode=Mode.CHARGE)
    for _ in range(2000):
        if model.status is not Status.CHARGING:
            break
        model.step(10.0)
        assert model.cell_voltage_v <= LAGGED.cell_charge_voltage_v + 1e-9
    assert model.status is Status.FULL


@pytest.mark.parametrize('name, value', [('surface_soc_lag_s', -1.0), ('tau_surface_s', 0.0),
                                         ('surface_soc_lag_s', 3601.0), ('surface_soc_lag_s', 1e6),
                                         ('surface_soc_lag_s', 1.7e308), ('surface_soc_lag_s', float('nan')),
                                         ('tau_surface_s', float('inf')), ('surface_soc_lag_s', 'abc')])
def test_a_bad_value_is_one_line_naming_it(name, value):
    with pytest.raises(ParameterError) as error:
        from_mapping({name: value})
    assert name in str(error.value) and '\n' not in str(error.value)


def test_the_longest_lag_charges_like_a_cell_and_its_state_resumes():
    """At MAX_SURFACE_SOC_LAG_S, a charge at the cell's largest charge current from 20 % ends Full near the
    top and the state it saves resumes (1e6 s, allowed before: Full at 20 % within 3 s, a saved lag of -1.43
    that restore_state refused)."""
    from battery_simulator.core.parameter_rules import MAX_SURFACE_SOC_LAG_S
    params = from_mapping({'surface_soc_lag_s': MAX_SURFACE_SOC_LAG_S})
    model = BatteryModel(params, state_of_charge=0.2, mode=Mode.IDLE)
    while model.status is not Status.FULL:
        model.step(10.0, current_a=params.cell_max_charge_current_a * 0.99)
    assert model.state_of_charge > 0.9
    again = BatteryModel(params, state_of_charge=0.5, mode=Mode.IDLE)
    again.restore_state(model.export_state())
    assert again.surface_soc_lag == model.surface_soc_lag
