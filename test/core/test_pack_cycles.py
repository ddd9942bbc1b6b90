"""A pack of groups over many cycles (issue 33, items 1 and 6, and the pack's Low items): no charge appears
in one group alone, alike groups cycle exactly as the lumped pack, and the config cannot draw a group that
cannot exist. No ROS; the charge is counted step by step from the pack's own throughput."""
import pytest

from battery_simulator.core.battery_model import BatteryModel
from battery_simulator.core.battery_states import CutOff, Mode, Status
from battery_simulator.core.config_files import from_mapping, preset
from battery_simulator.core.pack import GroupedPack, group_factors, make_model
from battery_simulator.core.parameter_rules import ParameterError

PACK = 'lg_hg2_7s4p'   # 7S4P HG2, 11.124 Ah


def cycles(model, count, dt_s=30.0, current_a=None, observe=None):
    """``count`` cycles of a discharge at ``current_a`` (default 1C) to the cut-off and a CC-CV charge to Full.
    Returns [(seconds to the cut-off, charge out per cell A*s, charge in per cell A*s)], counted step by
    step; ``observe(model)`` after every step."""
    current_a = -model.params.design_capacity_ah if current_a is None else current_a
    figures = []
    for _ in range(count):
        model.set_mode(Mode.DISCHARGE)
        runtime_s, charge_out, charge_in = 0.0, 0.0, 0.0
        while model.status is not Status.EMPTY:
            before = model.throughput_as
            model.step(dt_s, current_a=current_a)
            charge_out += before - model.throughput_as
            runtime_s += dt_s
            if observe:
                observe(model)
            assert runtime_s < 10 * 3600.0, 'no cut-off in 10 h'
        model.set_mode(Mode.CHARGE)
        charged_s = 0.0
        while model.status is not Status.FULL:
            before = model.throughput_as
            model.step(dt_s)
            charge_in += model.throughput_as - before
            charged_s += dt_s
            if observe:
                observe(model)
            assert charged_s < 10 * 3600.0, 'no Full in 10 h'
        figures.append((runtime_s, charge_out, charge_in))
    return figures


# -- item 1: a full charge created charge in the limiting group ---------------------------------------

def test_seven_alike_groups_cycle_as_the_lumped_pack_to_1e9_over_20_cycles():
    """On main the limiting group was set full alone at each charge's end (+1.1 %): the others fell behind
    1.1 % a cycle and the 1C runtime went 3556 -> 3515 -> 3475 s while the lumped pack's stayed."""
    lumped = make_model(preset(PACK), 1.0, mode=Mode.DISCHARGE)
    grouped = make_model(from_mapping({'preset': PACK, 'groups': [{}] * 7}), 1.0, mode=Mode.DISCHARGE)
    assert isinstance(grouped, GroupedPack) and not isinstance(lumped, GroupedPack)
    lumped_rows, grouped_rows = [], []
    lumped_cycles = cycles(lumped, 20, observe=lambda m: lumped_rows.append(m.snapshot()))
    grouped_cycles = cycles(grouped, 20, observe=lambda m: grouped_rows.append(m.snapshot()))
    assert len(lumped_rows) == len(grouped_rows), 'the same number of steps to every cut-off and Full'
    for number, (a, b) in enumerate(zip(lumped_rows, grouped_rows)):
        assert a.status is b.status, (number, a, b)
        for field in ('percentage', 'voltage_v', 'current_a', 'temperature_c', 'charge_ah', 'cycle_count',
                      'state_of_health'):
            x, y = getattr(a, field), getattr(b, field)
            assert abs(x - y) <= 1e-9 * max(1.0, abs(x)), (number, field, x, y)
    runtimes = [runtime for runtime, _, _ in grouped_cycles]
    assert runtimes == [runtime for runtime, _, _ in lumped_cycles]
    assert runtimes[0] - runtimes[-1] <= 30.0, 'only the capacity fade (20 cycles x 2e-4) shortens it: %s' % runtimes


def test_every_group_takes_the_same_charge_one_string_one_current():
    """A spread pack (no balancing, no fade: the arithmetic is the string's alone), 6 cycles. Each group's
    charge moves by eta x charge in - charge out, counted from the steps, and by nothing else: no step to
    100 % at a Full (issue 40; before, 1.1 % of a cell at every Full, and before issue 33 in the limiting
    group alone, about 0.11 Ah a charge on 7S4P)."""
    params = from_mapping({'preset': PACK, 'capacity_spread': 0.01, 'resistance_spread': 0.04, 'spread_seed': 2026,
                           'capacity_fade_per_cycle': 0.0})
    pack = make_model(params, 1.0, mode=Mode.DISCHARGE)
    start = [g.state_of_charge * g._capacity_as for g in pack.groups]
    figures = cycles(pack, 6)
    eta = params.coulombic_efficiency
    counted = sum(eta * charge_in - charge_out for _, charge_out, charge_in in figures)
    moved = [g.state_of_charge * g._capacity_as - q for g, q in zip(pack.groups, start)]
    steps = [m - counted for m in moved]   # what no current carried
    assert max(abs(s) for s in steps) < 1e-6 * 3600.0, 'nothing but the current (A*s per cell): %s' % steps
    runtimes = [runtime for runtime, _, _ in figures]
    assert max(runtimes) - min(runtimes) <= 30.0, 'no drift from cycle to cycle: %s' % runtimes


def test_the_aged_preset_keeps_its_runtime_over_20_cycles():
    """On main it lost 16 % of its 1C runtime in 20 cycles; now only its fade (2e-4 a cycle: 0.4 %)."""
    pack = make_model(preset('lg_hg2_7s4p_aged'), 1.0, mode=Mode.DISCHARGE)
    runtimes = [runtime for runtime, _, _ in cycles(pack, 20, dt_s=60.0)]
    assert runtimes[-1] >= runtimes[1] * (1.0 - 0.01) - 60.0, runtimes


# -- item 6: spreads that can draw a factor <= 0 ------------------------------------------------------

@pytest.mark.parametrize('key, value', [('capacity_spread', 0.4), ('capacity_spread', 0.9),
                                        ('resistance_spread', 0.9), ('resistance_spread', 1.0 / 3.0)])
def test_a_spread_that_can_draw_a_factor_at_or_below_zero_is_refused_naming_its_key(key, value):
    """On main 0.4 passed, and 7 seeds of 100 then failed naming cell_capacity_ah (a traceback)."""
    with pytest.raises(ParameterError) as refused:
        from_mapping({'preset': PACK, key: value}, origin='cfg')
    line = str(refused.value)
    assert line.startswith('cfg: parameter %s = %r is invalid: must be' % (key, value)) and '\n' not in line, line


def test_every_seed_of_the_largest_spread_allowed_draws_positive_factors():
    for seed in range(100):
        params = from_mapping({'preset': PACK, 'capacity_spread': 0.33, 'resistance_spread': 0.33,
                               'spread_seed': seed})
        assert all(c > 0.0 and r > 0.0 for c, r, _ in group_factors(params)), seed
        make_model(params, 0.5)


def test_an_empty_groups_list_is_refused_not_taken_for_a_lumped_pack():
    with pytest.raises(ParameterError, match=r'^cfg: parameter groups = \[\] is invalid: must be a list of'):
        from_mapping({'preset': PACK, 'groups': []}, origin='cfg')


# -- the Low items ----------------------------------------------------------------------------------

def test_at_the_cut_off_step_the_pack_reports_the_relaxed_voltage_as_the_lumped_pack_does():
    """On main a pack of groups reported the loaded voltage (about 0.3 V lower on 7S4P at 1C) at 0 A."""
    for params in (preset(PACK), from_mapping({'preset': PACK, 'groups': [{}] * 7})):
        model = make_model(params, 0.05, mode=Mode.DISCHARGE)
        while model.status is not Status.EMPTY:
            model.step(10.0, current_a=-11.124)
        s = model.snapshot()
        assert s.current_a == 0.0 and model.cut_off is CutOff.UNDER_VOLTAGE
        groups = getattr(model, 'groups', [model])
        relaxed = sum(g.open_circuit_voltage_v + g.rc_voltage_v + g.fast_rc_voltage_v for g in groups) \
            * 7 / len(groups)
        assert s.voltage_v == pytest.approx(relaxed, abs=1e-9), (type(model).__name__, s.voltage_v, relaxed)


def test_a_groups_resistance_factor_acts_on_its_voltage():
    """R0 x factor: at 2.781 A for 1 ms (the RC pairs hardly charged) a group with twice the resistance
    drops I R0 more. A model ignoring resistance_factor for R0 fails this."""
    params = from_mapping({'preset': 'lg_hg2_cell', 'cells_series': 2,
                           'groups': [{}, {'resistance_factor': 2.0}]})
    pack = make_model(params, 0.5, mode=Mode.IDLE)
    pack.step(1e-3, current_a=-2.781)
    normal, doubled = pack.groups
    r0 = normal._resistances.r0_at(0.5, False) * normal._resistance_scale()
    drop = (normal.open_circuit_voltage_v - normal.cell_voltage_v) - (doubled.open_circuit_voltage_v
                                                                      - doubled.cell_voltage_v)
    assert -drop == pytest.approx(2.781 * r0, rel=0.01), (drop, 2.781 * r0)


def test_a_lumped_model_refuses_a_config_of_groups_the_factory_builds_it():
    params = from_mapping({'preset': PACK, 'capacity_spread': 0.01})
    with pytest.raises(TypeError, match='make_model'):
        BatteryModel(params)
    assert isinstance(make_model(params), GroupedPack)
    assert type(make_model(preset(PACK))) is BatteryModel and type(make_model()) is BatteryModel


# -- issue 40, item 14: charge conserved to rounding, Full at SOC 1 on its own --------------------------

@pytest.mark.parametrize('name', [PACK, 'lg_hg2_7s4p_aged'])
def test_charge_is_conserved_over_20_cycles_and_every_full_is_soc_1(name):
    """|eta x charge in - charge out| <= 0.05 % of a cell's capacity per cycle (before: -1.1 %, the step
    from 0.989 to 1 at every Full), lumped and the aged 7S4P pack of 7 differing groups, balancing and a
    coulomb counter. The charge ends at SOC 1 on its own (the OCV table's top is fitted so: issue 40), and
    the step that ends it moves only what its current carried."""
    model = make_model(preset(name), 1.0, mode=Mode.DISCHARGE)
    eta = model.params.coulombic_efficiency
    cell_as = model.params.cell_capacity_ah * 3600.0
    fulls = []

    def at_full(m):
        if m.status is Status.FULL and (not fulls or fulls[-1][0] is not m):
            fulls.append((m, m.state_of_charge))
        elif m.status is not Status.FULL and fulls and fulls[-1][0] is m:
            fulls.append((None, None))
    figures = cycles(model, 20, dt_s=60.0, observe=at_full)
    errors = [(eta * charge_in - charge_out) / cell_as for _, charge_out, charge_in in figures]
    assert max(abs(e) for e in errors) <= 0.0005, ['%+.4f %%' % (100 * e) for e in errors]
    socs = [soc for m, soc in fulls if m is not None]
    assert len(socs) == 20 and all(abs(soc - 1.0) <= 1e-4 for soc in socs), socs
