"""A pack of differing groups and a fuel gauge that can be wrong (interface Part 5), against saved figures
and hand arithmetic. No ROS."""
import json

import pytest

from battery_simulator.core.battery_states import CutOff, Mode, Status
from battery_simulator.core.config_files import from_mapping, preset
from battery_simulator.core.pack import GroupedPack, group_factors, make_model
from battery_simulator.core.parameter_rules import ParameterError

import pack_scenarios

CELL = 'lg_hg2_cell'   # 2.781 Ah to 2.8 V at C/20


def cell_with(**changes):
    return from_mapping(dict(changes, preset=CELL))


def ageless_cell_with(**changes):
    """The cell without its capacity fade (2e-4 a cycle), so that the arithmetic is the gauge's alone."""
    return cell_with(capacity_fade_per_cycle=0.0, **changes)


def test_with_no_spread_and_an_ideal_gauge_the_figures_are_todays_to_1e9():
    with open(pack_scenarios.FIGURES) as stream:
        saved = json.load(stream)
    for name in pack_scenarios.NAMES:
        for old, new in zip(saved[name], pack_scenarios.scenario(name)):
            assert old[5] == new[5], (name, old, new)
            for a, b in zip(old[:5], new[:5]):
                assert abs(a - b) <= 1e-9 * max(1.0, abs(a)), (name, old, new)


# -- the gauge ------------------------------------------------------------------------------------

def discharge_until(model, charge_ah, current_a=-1.5, dt_s=10.0):
    """Discharge at ``current_a`` until ``charge_ah`` has left the pack (the last step cut to fit)."""
    left = charge_ah * 3600.0
    while left > 1e-9:
        step = min(dt_s, left / -current_a)
        model.step(step, current_a=current_a)
        left -= step * -current_a


def test_a_current_offset_of_30_ma_for_an_hour_at_1_5_a_puts_the_gauge_0_0108_ahead():
    model = make_model(ageless_cell_with(gauge={'model': 'coulomb_counter', 'current_offset_a': 0.03}), 1.0)
    discharge_until(model, 1.5)   # an hour at 1.5 A
    s = model.snapshot()
    # the sensor reads -1.47 A: 0.03 Ah too little counted, of the 2.781 Ah the gauge believes
    assert (s.percentage - s.true_percentage) / 100.0 == pytest.approx(0.03 / 2.781, abs=2e-5)
    assert 0.03 / 2.781 == pytest.approx(0.0108, abs=5e-5)


def test_a_capacity_belief_5_percent_high_puts_the_gauge_0_0257_ahead_after_1_5_ah_and_5_percent_at_the_cut_off():
    model = make_model(ageless_cell_with(gauge={'model': 'coulomb_counter', 'capacity_error': 0.05}), 1.0,
                         mode=Mode.DISCHARGE)
    discharge_until(model, 1.5)
    s = model.snapshot()
    ahead = (s.percentage - s.true_percentage) / 100.0
    assert ahead == pytest.approx(1.5 / 2.781 * (1.0 - 1.0 / 1.05), abs=2e-5)   # 0.5394 * 0.0476
    assert ahead == pytest.approx(0.0257, abs=5e-5)
    readings = []
    while model.status is not Status.EMPTY:
        readings.append((model.snapshot().percentage, model.snapshot().true_percentage))
        model.step(10.0, current_a=-1.5)
    # the gauge still believed about 5 %: 1 - (1 - SOC)/1.05, the truth at 2.8 V under load being about 1 % ...
    shown, true = readings[-1]
    assert shown == pytest.approx(100.0 * (1.0 - (1.0 - true / 100.0) / 1.05), abs=0.05) and 4.5 < shown < 6.5
    assert model.snapshot().percentage == 0.0, '... and snaps to 0 at the cut-off'
    assert model.cut_off is CutOff.UNDER_VOLTAGE


def test_the_gauge_recalibrates_at_full_and_its_gain_error_counts_every_ampere_hour():
    model = make_model(cell_with(gauge={'model': 'coulomb_counter', 'current_gain_error': 0.02,
                                          'initial_error': -3.0}), 0.5, mode=Mode.CHARGE)
    assert model.snapshot().percentage == pytest.approx(47.0), 'the initial error, in percentage points'
    before = model.snapshot()
    model.step(600.0)   # 10 min of 1.5 A CC: 0.25 Ah, counted 2 % high
    after = model.snapshot()
    counted = (after.percentage - before.percentage) - (after.true_percentage - before.true_percentage) / 0.999
    assert counted == pytest.approx(0.02 * (after.true_percentage - before.true_percentage) / 0.999, rel=0.02)
    while model.status is not Status.FULL:
        model.step(30.0)
    assert model.snapshot().percentage == 100.0


def test_an_ideal_gauge_refuses_gauge_error_and_a_counter_refuses_one_beyond_100():
    with pytest.raises(ValueError, match='gauge_error.*ideal'):
        make_model(preset(CELL), 0.5).set_state(gauge_error=5.0)
    model = make_model(cell_with(gauge={'model': 'coulomb_counter'}), 0.97)
    with pytest.raises(ValueError, match=r'gauge_error = 5.0 is invalid: it puts the gauge at 102.0 %'):
        model.set_state(gauge_error=5.0)
    assert model.snapshot().percentage == pytest.approx(97.0), 'nothing changed'
    model.set_state(gauge_error=-7.0)
    assert model.snapshot().percentage == pytest.approx(90.0) and model.snapshot().true_percentage == pytest.approx(97.0)


def test_a_stuck_gauge_freezes_what_the_robot_reads_while_the_truth_moves_on():
    model = make_model(preset(CELL), 0.8, mode=Mode.DISCHARGE)
    model.set_gauge_stuck(True)
    model.step(1800.0)
    s = model.snapshot()
    assert s.percentage == pytest.approx(80.0) and s.true_percentage < 80.0 - 10.0
    model.set_gauge_stuck(False)
    assert model.snapshot().percentage == pytest.approx(model.snapshot().true_percentage)


# -- the pack of groups ------------------------------------------------------------------------

def hg2_2s(**changes):
    """2S of the LG HG2 cell."""
    return cell_with(cells_series=2, **changes)


def cut_off_time_s(model, current_a=-2.781, dt_s=5.0):
    t = 0.0
    while model.status is not Status.EMPTY and t < 1e5:
        model.step(dt_s, current_a=current_a)
        t += dt_s
    return t


def test_the_weakest_group_ends_the_discharge():
    """The two measured cells: 2.693 Ah against 2.726 Ah to 2.8 V at 1C (1.2 % less). A 2S pack of them
    cuts off when the weaker is empty, about 1.2 % of the discharge (about 40 s at 1C) earlier than a
    lumped pack of two stronger cells, which cannot show it."""
    weak = 2.693 / 2.726
    lumped = cut_off_time_s(make_model(hg2_2s(), 1.0, mode=Mode.DISCHARGE))
    pack = make_model(hg2_2s(groups=[{}, {'capacity_factor': weak}]), 1.0, mode=Mode.DISCHARGE)
    assert isinstance(pack, GroupedPack)
    grouped = cut_off_time_s(pack)
    assert 0.008 < (lumped - grouped) / lumped < 0.016, (lumped, grouped)
    strong, weaker = pack.groups
    assert loaded_voltage_v(weaker, -2.781) == pytest.approx(2.8, abs=0.01), 'the weaker group is at the cut-off'
    assert loaded_voltage_v(strong, -2.781) > 2.85
    assert strong.state_of_charge > weaker.state_of_charge + 0.008, 'the stronger one still holds charge'


def loaded_voltage_v(group, cell_current_a):
    """A group's cell voltage were ``cell_current_a`` flowing (after the cut-off none does)."""
    r0 = group._resistances.r0_at(group.state_of_charge, cell_current_a > 0.0) * group._resistance_scale()
    return group.open_circuit_voltage_v + group.rc_voltage_v + group.fast_rc_voltage_v + cell_current_a * r0


def test_an_imbalanced_pack_charges_to_less_than_full_the_highest_group_holding_the_cv():
    pack = make_model(hg2_2s(groups=[{'initial_soc_offset': 0.05}, {'initial_soc_offset': -0.05}]), 0.5,
                        mode=Mode.CHARGE)
    while pack.status is not Status.FULL:
        pack.step(10.0)
        # the highest group held at 4.2 V (within what the lumped model itself allows at 10 s steps: 0.4 mV)
        assert max(pack.snapshot().cell_voltages_v) <= 4.2 + 5e-4
    high, low = pack.groups
    assert high.state_of_charge == 1.0 and low.state_of_charge < 0.92, (high.state_of_charge, low.state_of_charge)
    assert pack.snapshot().true_percentage == 100.0, 'the pack takes no more: full as a BMS says it'
    lumped = make_model(hg2_2s(), 1.0)
    assert pack.snapshot().charge_ah < 0.93 * lumped.snapshot().charge_ah + 1e-9, 'but it holds less charge'


def test_balancing_shrinks_the_spread_at_the_rate_its_bleed_current_implies():
    bleed_a = 0.1
    pack = make_model(hg2_2s(groups=[{}, {'initial_soc_offset': 0.04}],
                               balancing={'current_a': bleed_a, 'start_voltage_v': 3.3, 'threshold_v': 0.001}),
                        0.3, mode=Mode.CHARGE)
    low, high = pack.groups
    spread_before = high.state_of_charge - low.state_of_charge
    bleeding_s = 0.0
    for _ in range(120):   # 20 min of CC, far from the CV phase
        pack.step(10.0)
        bleeding_s += 10.0 * pack.bleeding[1]
        assert not pack.bleeding[0], 'the lowest group never bleeds'
    assert bleeding_s > 600.0
    # both groups take the string's current; the higher one takes bleed_a less the whole time it bleeds
    # (a charge current: stored with the coulombic efficiency, 0.999)
    expected = spread_before - 0.999 * bleed_a * bleeding_s / (2.781 * 3600.0)
    assert high.state_of_charge - low.state_of_charge == pytest.approx(expected, abs=2e-6)
    assert high.temperature_c > low.temperature_c, 'the bleed resistor heats its group'


def test_spreads_draw_the_same_pack_from_the_same_seed():
    params = from_mapping({'preset': 'lg_hg2_7s4p', 'capacity_spread': 0.01, 'resistance_spread': 0.03,
                           'spread_seed': 7})
    first, again = group_factors(params), group_factors(params)
    assert first == again and len(first) == 7 and len({c for c, _, _ in first}) == 7
    other = group_factors(from_mapping({'preset': 'lg_hg2_7s4p', 'capacity_spread': 0.01, 'spread_seed': 8}))
    assert other != first


def test_a_grouped_pack_resumes_its_groups_and_its_gauge():
    params = hg2_2s(groups=[{}, {'capacity_factor': 0.97}], gauge={'model': 'coulomb_counter',
                                                                  'current_offset_a': 0.05})
    pack = make_model(params, 0.9, mode=Mode.DISCHARGE)
    pack.step(1800.0)
    saved = json.loads(json.dumps(pack.export_state()))
    again = make_model(params, 1.0, mode=Mode.DISCHARGE)
    again.restore_state(saved)
    assert [g.state_of_charge for g in again.groups] == pytest.approx([g.state_of_charge for g in pack.groups])
    assert again.snapshot().percentage == pytest.approx(pack.snapshot().percentage)
    assert again.snapshot().true_percentage == pytest.approx(pack.snapshot().true_percentage)
    lumped = make_model(preset(CELL), 1.0)
    lumped.restore_state({k: v for k, v in saved.items() if k not in ('groups', 'gauge_soc')})


@pytest.mark.parametrize('changes, named', [
    ({'cells_series': 2, 'groups': [{}]}, 'groups'),
    ({'cells_series': 2, 'groups': [{}, {'capacity_factor': -1.0}]}, 'groups[1].capacity_factor'),
    ({'capacity_spread': 1.0}, 'capacity_spread'),
    ({'resistance_spread': -0.1}, 'resistance_spread'),
    ({'balancing': {'current_a': 2.0, 'start_voltage_v': 4.0, 'threshold_v': 0.01}}, 'balancing.current_a'),
    ({'gauge': {'model': 'coulomb_counter', 'initial_error': 150.0}}, 'gauge.initial_error'),
    ({'gauge': {'model': 'magic'}}, 'gauge'),
])
def test_bad_pack_and_gauge_keys_are_named(changes, named):
    with pytest.raises(ParameterError, match=r'parameter %s = ' % named.replace('[', r'\[').replace(']', r'\]')):
        cell_with(**changes)
