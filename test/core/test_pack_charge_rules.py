"""The pack's charge rules (interface Part 5; issue 40, item 16), step by step and by hand arithmetic. No ROS.

- The constant-voltage phase holds the HIGHEST group (by its voltage) at the cell charge voltage: the string's
  one current is the least any group's CC-CV allows, so no group passes 4.2 V and every group carries it.
- Balancing may start once the highest group's voltage, as the step begins, is at or above
  ``start_voltage_v``, only while charging; then every group more than ``threshold_v`` above the lowest
  bleeds ``current_a`` (at most the string's current).

Planted bugs in these rules (the CV held on another group, a group charged past the others, balancing on
the lowest group's voltage, or before the start voltage, or while discharging) survived the tests before.
"""
import math

import pytest

from battery_simulator.core.battery_states import CutOff, Mode, Status
from battery_simulator.core.config_files import from_mapping
from battery_simulator.core.pack import GroupedPack, make_model

CAPACITY_AS = 2.781 * 3600.0   # one lg_hg2_cell, A*s
EFFICIENCY = 0.999             # its coulombic efficiency


def two_groups(groups, **changes):
    """2S of the LG HG2 cell, ageless (the arithmetic is the string's alone)."""
    params = from_mapping(dict(changes, preset='lg_hg2_cell', cells_series=2, groups=groups,
                               capacity_fade_per_cycle=0.0))
    return params


def test_the_cv_phase_holds_the_highest_group_at_the_charge_voltage_with_one_current_in_every_group():
    """The higher group is the SECOND one (a rule that holds the first group, or the lowest, fails here).
    Equal capacities and one current: the SOC spread (0.06) stays exactly as it was to the end."""
    pack = make_model(two_groups([{'initial_soc_offset': -0.03}, {'initial_soc_offset': 0.03}],
                                 charger_holds_full=False), 0.85, mode=Mode.CHARGE)
    assert isinstance(pack, GroupedPack)
    low, high = pack.groups
    demand = pack.params.charge_current_a   # 1.5 A
    cv_steps = 0
    while pack.status is Status.CHARGING:
        pack.step(10.0)
        if pack.status is not Status.CHARGING:
            break
        # one string: both groups carry the pack's current
        assert low.cell_current_a == high.cell_current_a == pytest.approx(pack.current_a, rel=1e-12)
        assert high.cell_voltage_v > low.cell_voltage_v
        # no group above the charge voltage (within what the lumped model allows at 10 s steps: 1 mV)
        assert high.cell_voltage_v <= 4.2 + 1e-3
        if pack.current_a < demand * (1.0 - 1e-9):   # the CV phase: the highest group is held at 4.2 V
            cv_steps += 1
            assert high.cell_voltage_v == pytest.approx(4.2, abs=1e-3), (cv_steps, high.cell_voltage_v)
            assert low.cell_voltage_v < 4.2 - 0.01
    assert cv_steps > 100 and pack.status is Status.FULL
    assert high.state_of_charge - low.state_of_charge == pytest.approx(0.06, abs=1e-9), 'the spread kept'
    assert high.state_of_charge == pytest.approx(1.0, abs=5e-4), 'the highest group is full'
    assert pack.snapshot().true_percentage == pytest.approx(100.0, abs=0.05)
    assert pack.snapshot().current_a == 0.0 and low.cell_current_a == high.cell_current_a == 0.0, 'the charger off'


def test_the_highest_group_by_voltage_not_by_charge_holds_the_cv():
    """Group 0 holds less charge (SOC 0.96 against 0.97) but has three times the resistance: its voltage
    is the higher through the CV phase, so it is the one held at 4.2 V, and the other stays below."""
    pack = make_model(two_groups([{'resistance_factor': 3.0, 'initial_soc_offset': -0.005},
                                  {'initial_soc_offset': 0.005}]), 0.965, mode=Mode.CHARGE)
    resistive, other = pack.groups
    held = 0
    for _ in range(60):   # 10 min of CV
        pack.step(10.0)
        if pack.status is not Status.CHARGING:
            break
        assert resistive.cell_current_a == other.cell_current_a
        if pack.current_a < pack.params.charge_current_a - 1e-9:
            held += 1
            assert resistive.cell_voltage_v == pytest.approx(4.2, abs=1e-3)
            assert other.cell_voltage_v < resistive.cell_voltage_v - 0.002
    assert held > 20
    assert resistive.state_of_charge < other.state_of_charge


def expected_bleeds(voltages, bleed_a, start_v, threshold_v, current_a):
    """Part 5's rule by hand: with the highest group at or above the start voltage as the step begins,
    every group more than the threshold above the lowest bleeds (at most the string's current)."""
    if max(voltages) < start_v:
        return [0.0] * len(voltages)
    return [min(bleed_a, current_a) if v - min(voltages) > threshold_v else 0.0 for v in voltages]


def test_balancing_starts_when_the_highest_group_reaches_the_start_voltage_and_bleeds_as_the_rule_says():
    """2S at SOC 0.5 and 0.54, charged at 1.5 A, start 3.9 V: for a while the higher group is above
    3.9 V and the lower below it (balancing on; a rule on the lowest group's voltage fails), and before
    that neither is (balancing off; a rule that ignores the start fails). Each step's bleeds are
    checked against the voltages as the step began, and the spread against the arithmetic:
    unchanged without a bleed (one current, equal capacities), closing eta x 0.1 A / C a second with."""
    bleed_a, start_v, threshold_v = 0.1, 3.9, 0.01
    pack = make_model(two_groups([{}, {'initial_soc_offset': 0.04}],
                                 balancing={'current_a': bleed_a, 'start_voltage_v': start_v,
                                            'threshold_v': threshold_v}), 0.5, mode=Mode.CHARGE)
    low, high = pack.groups
    spread = high.state_of_charge - low.state_of_charge
    phases = set()
    for _ in range(400):
        voltages = [g.cell_voltage_v for g in pack.groups]   # as the step begins
        pack.step(10.0)
        assert pack.status is Status.CHARGING
        current = pack.current_a
        bleeds = expected_bleeds(voltages, bleed_a, start_v, threshold_v, current)
        assert pack.bleeding == [b > 0.0 for b in bleeds], (voltages, pack.bleeding)
        assert low.cell_current_a == pytest.approx(current - bleeds[0], abs=1e-12)
        assert high.cell_current_a == pytest.approx(current - bleeds[1], abs=1e-12)
        spread -= EFFICIENCY * (bleeds[1] - bleeds[0]) * 10.0 / CAPACITY_AS
        assert high.state_of_charge - low.state_of_charge == pytest.approx(spread, abs=1e-9)
        phases.add((max(voltages) >= start_v, min(voltages) >= start_v))
        if min(voltages) >= start_v:
            break
    assert phases >= {(False, False), (True, False), (True, True)}, 'off, on with the lower group below 3.9 V'
    assert spread < 0.04 - 0.002, 'the bleed closed the spread'


def test_balancing_never_acts_while_discharging_or_at_rest():
    """Above the start voltage and far apart, but no charge: no bleed, the spread unchanged."""
    pack = make_model(two_groups([{}, {'initial_soc_offset': 0.05}],
                                 balancing={'current_a': 0.1, 'start_voltage_v': 3.0, 'threshold_v': 0.001}),
                      0.9, mode=Mode.DISCHARGE)
    low, high = pack.groups
    spread = high.state_of_charge - low.state_of_charge
    for mode in (Mode.DISCHARGE, Mode.IDLE):
        pack.set_mode(mode)
        for _ in range(30):
            pack.step(10.0)
            assert pack.bleeding == [False, False]
            assert low.cell_current_a == high.cell_current_a
    assert high.state_of_charge - low.state_of_charge == pytest.approx(spread, abs=1e-12)


def test_a_bleed_is_never_more_than_the_string_current():
    """Late in the CV phase the string's current falls below a 0.3 A bleed: the bleeding group then takes
    nothing (not a negative current: the bleed resistor takes what the string brings, no more)."""
    pack = make_model(two_groups([{}, {'initial_soc_offset': 0.02}],
                                 balancing={'current_a': 0.3, 'start_voltage_v': 3.5, 'threshold_v': 0.001}),
                      0.9, mode=Mode.CHARGE)
    low, high = pack.groups
    below = 0
    while pack.status is Status.CHARGING:
        pack.step(10.0)
        if pack.status is Status.CHARGING and pack.bleeding[1] and pack.current_a < 0.3:
            below += 1
            assert high.cell_current_a == 0.0 and low.cell_current_a == pytest.approx(pack.current_a)
        assert high.cell_current_a >= 0.0
    assert below > 0


def group_charges_as(pack):
    return [g.state_of_charge * g._capacity_as for g in pack.groups]


def test_large_steps_into_the_cv_phase_keep_one_current_no_group_above_4v2_and_move_only_what_flowed():
    """Steps of 20 min from the CC phase into the CV phase: within a step the highest group reaches 4.2 V,
    so the string's current is the least the groups' CC-CV allows (tried group by group). Every group
    carries it, none passes 4.2 V by more than the lumped model does, and each group's charge moves by
    eta x that current x the step."""
    pack = make_model(two_groups([{'resistance_factor': 2.0}, {'initial_soc_offset': 0.03}]), 0.75,
                      mode=Mode.CHARGE)
    assert max(g.cell_voltage_v for g in pack.groups) < 4.2 - 0.15, 'the first step starts in the CC phase'
    limited = 0
    while pack.status is Status.CHARGING:
        before = group_charges_as(pack)
        pack.step(1200.0)
        current = pack.snapshot().current_a
        if pack.status is Status.CHARGING:
            assert pack.groups[0].cell_current_a == pack.groups[1].cell_current_a == pytest.approx(current)
            # (at such steps the lumped model itself ends a CV step up to tens of mV high: resistances by SOC)
            assert max(g.cell_voltage_v for g in pack.groups) <= 4.2 + 0.05
            limited += current < pack.params.charge_current_a - 1e-9
            for start, group in zip(before, pack.groups):
                assert group.state_of_charge * group._capacity_as - start == pytest.approx(
                    EFFICIENCY * current * 1200.0, rel=1e-9)
    assert limited >= 1 and pack.status is Status.FULL


def test_a_pack_whose_taper_ends_at_its_termination_current_ends_there_moving_nothing():
    """A termination current of 0.5 A: the taper ends well before any group is full. The step that ends it
    carries no current (no charge counted, none moved), the pack reads FULL at 0 A (a charger that
    switches off), and it stays so."""
    pack = make_model(two_groups([{}, {'initial_soc_offset': 0.02}], termination_current_a=0.5,
                                 charger_holds_full=False), 0.9, mode=Mode.CHARGE)
    while pack.status is Status.CHARGING:
        before = (group_charges_as(pack), pack.throughput_as, pack.snapshot().current_a)
        pack.step(10.0)
    charges, throughput, last_current = before
    assert pack.status is Status.FULL and 0.5 < last_current < 0.6
    assert group_charges_as(pack) == charges and pack.throughput_as == throughput
    assert pack.snapshot().current_a == 0.0 and all(g.cell_current_a == 0.0 for g in pack.groups)
    assert max(g.state_of_charge for g in pack.groups) < 0.995, 'ended by the taper, not by a full group'
    pack.step(60.0)
    assert pack.status is Status.FULL and group_charges_as(pack) == charges


def test_a_pack_with_a_charger_fault_or_an_over_current_charges_nothing():
    pack = make_model(two_groups([{}, {'initial_soc_offset': 0.02}]), 0.5, mode=Mode.CHARGE)
    charges = group_charges_as(pack)
    pack.set_charger_fault(True)
    pack.step(60.0)
    assert (pack.status, pack.snapshot().current_a, group_charges_as(pack)) == (Status.NOT_CHARGING, 0.0, charges)
    pack.set_charger_fault(False)
    pack.step(60.0, current_a=4.5)   # above the cell's 4 A maximum charge current
    assert (pack.status, pack.cut_off, pack.snapshot().current_a) == (Status.NOT_CHARGING, CutOff.OVER_CURRENT, 0.0)
    assert group_charges_as(pack) == charges
    pack.step(60.0, current_a=4.0)   # exactly the maximum: allowed
    assert pack.status is Status.CHARGING and pack.cut_off is None
    assert pack.groups[0].cell_current_a == pack.groups[1].cell_current_a == 4.0


def test_a_bleed_resistor_heats_its_group_as_the_lumped_thermal_mass_says():
    """_heat: P held over dt into a mass C exchanging G with ambient: a rise of P/G (1 - exp(-dt G / C))."""
    pack = make_model(two_groups([{}, {}]), 0.5, mode=Mode.IDLE)
    group = pack.groups[1]
    p = pack.params
    before = group.temperature_c
    pack._heat(group, 0.5, 120.0)
    rise = 0.5 / p.cell_heat_transfer_w_per_k * (1.0 - math.exp(-120.0 * p.cell_heat_transfer_w_per_k
                                                                / p.cell_heat_capacity_j_per_k))
    assert group.temperature_c - before == pytest.approx(rise, rel=1e-12)


def test_set_state_puts_every_group_there_and_a_refused_one_changes_no_group():
    params = two_groups([{'capacity_factor': 0.98}, {'initial_soc_offset': 0.03}],
                        gauge={'model': 'coulomb_counter'})
    pack = make_model(params, 0.8, mode=Mode.IDLE)
    pack.set_state(state_of_charge=0.4, temperature_c=31.0, state_of_health=0.9, gauge_error=2.0)
    assert [g.state_of_charge for g in pack.groups] == [0.4, 0.4]
    assert [g.temperature_c for g in pack.groups] == [31.0, 31.0]
    assert [g.state_of_health for g in pack.groups] == [0.9, 0.9]
    assert pack.snapshot().percentage == pytest.approx(42.0) and pack.snapshot().true_percentage == pytest.approx(40.0)
    states = [g._state() for g in pack.groups]
    with pytest.raises(ValueError):
        pack.set_state(state_of_charge=0.6, temperature_c=31.0, state_of_health=0.9, gauge_error=80.0)
    assert [g._state() for g in pack.groups] == states


def test_a_pack_resumes_from_a_state_saved_without_its_groups():
    """A lumped pack's state file given to a pack of groups: every group resumes from the pack's values."""
    lumped = make_model(from_mapping({'preset': 'lg_hg2_cell', 'cells_series': 2}), 0.7, mode=Mode.IDLE)
    pack = make_model(two_groups([{}, {'initial_soc_offset': 0.02}]), 1.0, mode=Mode.IDLE)
    pack.restore_state(lumped.export_state())
    assert [g.state_of_charge for g in pack.groups] == pytest.approx([0.7, 0.7])


def test_a_constant_power_load_on_alike_groups_is_the_lumped_packs_to_1e9():
    """2S2P: the string's current for a power load is the lumped rule over the sum of the groups' EMFs and
    resistances (P per parallel string, I per cell)."""
    params = from_mapping({'preset': 'lg_hg2_cell', 'cells_series': 2, 'cells_parallel': 2})
    lumped = make_model(params, 0.8, mode=Mode.IDLE)
    pack = make_model(from_mapping({'preset': 'lg_hg2_cell', 'cells_series': 2, 'cells_parallel': 2,
                                    'groups': [{}, {}]}), 0.8, mode=Mode.IDLE)
    for power_w, current_a in ((-30.0, None), (-12.0, None), (None, -2.0)):
        for model in (lumped, pack):
            model.step(30.0, power_w=power_w, current_a=current_a)
        assert pack.snapshot().current_a == pytest.approx(lumped.snapshot().current_a, rel=1e-9)
        assert pack.snapshot().voltage_v == pytest.approx(lumped.snapshot().voltage_v, rel=1e-9)
    assert pack.state_of_charge == pytest.approx(lumped.state_of_charge, rel=1e-9)


def test_the_bleed_resistor_takes_its_current_times_the_group_voltage_per_cell():
    """2S2P with a 0.2 A bleed per pack string: each bleeding step puts 0.2 A x V_group / 2 cells into
    each cell of the group (the heat a bleed resistor across the group dissipates, shared by its cells)."""
    pack = make_model(two_groups([{}, {'initial_soc_offset': 0.04}], cells_parallel=2, charge_current_a=3.0,
                                 balancing={'current_a': 0.2, 'start_voltage_v': 3.0, 'threshold_v': 0.001}),
                      0.5, mode=Mode.CHARGE)
    calls = []
    real_heat = pack._heat
    pack._heat = lambda group, power, dt: calls.append((group, power, dt)) or real_heat(group, power, dt)
    pack.step(10.0)
    assert pack.bleeding == [False, True]
    (group, power, dt), = calls
    assert group is pack.groups[1] and dt == 10.0
    # (the group's voltage as its step ended; the heat itself then moves it by a few uV through Arrhenius)
    assert power == pytest.approx(0.2 * group.cell_voltage_v / 2, rel=1e-5)


def test_a_new_pack_bleeds_nothing_and_its_groups_end_their_taper_at_the_packs_termination_current():
    """A spread pack with the C/20 default: every group's taper ends at the pack's C/20 (of the design
    capacity), not at its own (its capacity differs), and no group bleeds before a charge."""
    params = from_mapping({'preset': 'lg_hg2_cell', 'cells_series': 2, 'termination_current_a': None,
                           'groups': [{'capacity_factor': 0.9}, {}],
                           'balancing': {'current_a': 0.05, 'start_voltage_v': 4.1, 'threshold_v': 0.01}})
    pack = make_model(params, 0.5, mode=Mode.IDLE)
    assert pack.bleeding == [False, False]
    assert [g.params.pack_termination_current_a for g in pack.groups] == [2.781 / 20] * 2
    assert [g.params.cells_series for g in pack.groups] == [1, 1]


def test_a_pack_at_rest_carries_nothing_and_relaxes_and_a_small_charge_current_charges():
    """At rest: NOT_CHARGING, 0 A, no charge counted, every group's RC voltage relaxing, no bleed left
    from the charge before. A charge of 0.5 A (below a cell's 1 A) charges every group by eta x 0.5 A x dt."""
    pack = make_model(two_groups([{}, {'initial_soc_offset': 0.04}],
                                 balancing={'current_a': 0.1, 'start_voltage_v': 3.0, 'threshold_v': 0.001}),
                      0.5, mode=Mode.CHARGE)
    pack.step(60.0)
    assert pack.bleeding == [False, True]
    pack.set_mode(Mode.IDLE)
    rc = [g.rc_voltage_v for g in pack.groups]
    charges, throughput = group_charges_as(pack), pack.throughput_as
    pack.step(600.0)
    assert (pack.status, pack.snapshot().current_a, pack.throughput_as) == (Status.NOT_CHARGING, 0.0, throughput)
    assert group_charges_as(pack) == charges and pack.bleeding == [False, False]
    assert all(0.0 < g.rc_voltage_v < r for g, r in zip(pack.groups, rc)), 'relaxing after the charge'
    before, throughput = group_charges_as(pack), pack.throughput_as
    pack.step(100.0, current_a=0.5)
    assert pack.throughput_as - throughput == pytest.approx(0.5 * 100.0, rel=1e-12), 'counted in, per cell'
    for start, group in zip(before, pack.groups):
        bleed = 0.1 if pack.bleeding[pack.groups.index(group)] else 0.0
        assert group.state_of_charge * group._capacity_as - start == pytest.approx(
            EFFICIENCY * (0.5 - bleed) * 100.0, rel=1e-9)


@pytest.mark.parametrize('current_a, power_w', [(1.0, 10.0), (0.0, 0.5)])
def test_the_modes_load_of_a_current_and_a_power_on_alike_groups_is_the_lumped_packs(current_a, power_w):
    """The mode's demand: load_current_a and load_power_w together (and a power under 1 W), 2S2P."""
    keys = {'preset': 'lg_hg2_cell', 'cells_series': 2, 'cells_parallel': 2, 'load_current_a': current_a,
            'load_power_w': power_w}
    lumped = make_model(from_mapping(keys), 0.8, mode=Mode.DISCHARGE)
    pack = make_model(from_mapping(dict(keys, groups=[{}, {}])), 0.8, mode=Mode.DISCHARGE)
    for model in (lumped, pack):
        model.step(60.0)
    assert pack.snapshot().current_a == pytest.approx(lumped.snapshot().current_a, rel=1e-9)
    assert pack.snapshot().voltage_v == pytest.approx(lumped.snapshot().voltage_v, rel=1e-9)


def test_a_power_beyond_what_the_pack_can_deliver_cuts_it_off():
    pack = make_model(two_groups([{}, {}]), 0.8, mode=Mode.IDLE)
    pack.step(1.0, power_w=-1e5)
    assert (pack.status, pack.cut_off, pack.snapshot().current_a) == (Status.EMPTY, CutOff.POWER_LIMIT, 0.0)


@pytest.mark.parametrize('tries, ends', [
    ([(1.0, False), (1.2, True)], True),     # the group whose taper ended is not the one allowing least
    ([(1.2, True), (1.0, False)], True),
    ([(0.0, False), (1.2, False)], True),    # a group that allows nothing (a full one) ends the string's charge
    ([(1.0, False), (1.2, False)], False),   # none ended: the least current flows in every group
])
def test_the_string_charge_ends_when_any_groups_taper_ended_whichever_group_allows_least(tries, ends):
    """The general path (every group tried): a taper ended in ANY group ends the charge (FULL, 0 A), not only
    in the group that allows the least current; else every group carries the least current. Each group's
    try is given (its current, its taper ended); its state after the try is its state now."""
    pack = make_model(two_groups([{}, {}], charger_holds_full=False), 0.9, mode=Mode.CHARGE)
    outcomes = {index: (current, pack.groups[index]._state(), ended) for index, (current, ended) in enumerate(tries)}
    pack._try = lambda index, dt_s, demand: outcomes[index]
    pack._voltages = [g.cell_voltage_v for g in pack.groups]
    current = pack._charge_tried(1.0, 1.5)
    if ends:
        assert current == 0.0 and pack.status is Status.FULL
        assert [g.cell_current_a for g in pack.groups] == [0.0, 0.0]
    else:
        assert current == 1.0 and pack.status is Status.CHARGING
        assert [g.cell_current_a for g in pack.groups] == [1.0, 1.0]


def test_the_spreads_draw_is_centred_on_the_nominal_group_and_clipped_at_3_sigma():
    """group_factors draws each factor as 1 + spread x N(0, 1) clipped to +-3 sigma: over 4000 groups the
    draws (factor - 1) / spread have a mean within 0.05 of 0 and a standard deviation within 0.05 of 1 (a
    draw centred on 1 sigma would give a pack whose groups are all larger than the config says)."""
    import statistics
    from types import SimpleNamespace

    from battery_simulator.core.pack import SPREAD_SIGMAS, group_factors
    params = SimpleNamespace(groups=(), spread_seed=3, capacity_spread=0.05, resistance_spread=0.1, cells_series=4000)
    factors = group_factors(params)
    for column, spread in ((0, 0.05), (1, 0.1)):
        draws = [(f[column] - 1.0) / spread for f in factors]
        assert abs(statistics.fmean(draws)) < 0.05 and abs(statistics.pstdev(draws) - 1.0) < 0.05
        assert max(abs(d) for d in draws) <= SPREAD_SIGMAS + 1e-12
    assert all(f[2] == 0.0 for f in factors)
