"""The coulomb counter's rules one by one (core/gauge.py), by hand arithmetic (issue 40, item 16). No ROS.

Each test pins one rule the mutation run (tools/mutation.sh gauge) found unpinned: the recalibration
switches, the deadband's edges, the clamps to 0 and 1, a zero-length step, and add_error's range and text.
"""
import pytest

from battery_simulator.core.gauge import CoulombCounter

CAPACITY_AH = 2.5   # believed capacity 9000 A*s: numbers that stay exact


def counter(soc=0.5, **config):
    return CoulombCounter(config, CAPACITY_AH, soc)


def test_recalibrate_at_full_false_counts_past_99_percent_and_does_not_snap_at_full():
    gauge = counter(0.98, recalibrate_at_full=False)
    gauge.count(900.0, 100.0)   # +0.1 of 9000 A*s: 0.98 -> 1.0 (clamped), no hold at 0.99
    assert gauge.soc == 1.0
    gauge = counter(0.5, recalibrate_at_full=False)
    gauge.on_full()
    assert gauge.soc == 0.5
    held = counter(0.98)
    held.count(900.0, 100.0)
    assert held.soc == 0.99, 'a gauge that recalibrates at full holds at 99 % until the charge ends'
    held.on_full()
    assert held.soc == 1.0


def test_recalibrate_at_empty_false_does_not_snap_at_the_cut_off():
    gauge = counter(0.07, recalibrate_at_empty=False)
    gauge.on_empty()
    assert gauge.soc == 0.07
    gauge = counter(0.07)
    gauge.on_empty()
    assert gauge.soc == 0.0


def test_the_deadband_is_inclusive_at_both_edges():
    """deadband 0.5 A over 2 s: a measured 1.0 A*s either way counts as nothing; 1.0 + 9 A*s counts."""
    gauge = counter(0.5, deadband_a=0.5)
    gauge.count(1.0, 2.0)
    gauge.count(-1.0, 2.0)
    assert gauge.soc == 0.5
    gauge.count(9.0, 2.0)
    assert gauge.soc == pytest.approx(0.5 + 9.0 / 9000.0, abs=1e-15)


def test_a_zero_length_step_counts_nothing_and_half_a_second_counts():
    gauge = counter(0.5)
    gauge.count(90.0, 0.0)
    assert gauge.soc == 0.5
    gauge.count(90.0, 0.5)
    assert gauge.soc == pytest.approx(0.51, abs=1e-15)


def test_the_count_is_clamped_to_0_and_1():
    gauge = counter(0.01)
    gauge.count(-900.0, 100.0)   # -0.1 from 0.01
    assert gauge.soc == 0.0
    gauge = counter(0.95, recalibrate_at_full=False)
    gauge.count(900.0, 100.0)    # +0.1 from 0.95
    assert gauge.soc == 1.0


def test_add_error_allows_exactly_0_and_100_and_names_where_it_would_put_the_gauge():
    gauge = counter(0.5)
    gauge.add_error(-50.0)
    assert gauge.soc == 0.0
    gauge = counter(0.5)
    gauge.add_error(50.0)
    assert gauge.soc == 1.0
    gauge = counter(0.5)
    with pytest.raises(ValueError) as refused:
        gauge.add_error(120.0)   # 1.7
    assert str(refused.value) == ('gauge_error = 120.0 is invalid: it puts the gauge at 170.0 % (now 50.0 %): '
                                  'the percentage must stay in [0, 100]')
    with pytest.raises(ValueError) as refused:
        gauge.add_error(-60.0)   # -0.1
    assert str(refused.value) == ('gauge_error = -60.0 is invalid: it puts the gauge at -10.0 % (now 50.0 %): '
                                  'the percentage must stay in [0, 100]')
    assert gauge.soc == 0.5, 'refused: nothing changed'


def test_an_explicit_ideal_gauge_is_none_a_counter_otherwise():
    from battery_simulator.core.gauge_models import make_gauge
    assert make_gauge({'model': 'ideal'}, 2.5, 0.5) is None and make_gauge(None, 2.5, 0.5) is None
    assert isinstance(make_gauge({'model': 'coulomb_counter'}, 2.5, 0.5), CoulombCounter)


def counter_pack(soc):
    from battery_simulator.core.battery_states import Mode
    from battery_simulator.core.config_files import from_mapping
    from battery_simulator.core.pack import make_model
    return make_model(from_mapping({'preset': 'lg_hg2_3s1p', 'gauge': {'model': 'coulomb_counter'}}), soc, Mode.IDLE)


def test_a_model_stepped_in_half_seconds_counts_every_step():
    """The model's steps reach the count (after_step) whatever their length: 600 steps of 0.5 s take 4.5 %
    of the pack, and the counter (no error) moves with the truth (to its ageing: 2e-7)."""
    from battery_simulator.core.battery_states import Mode
    model = counter_pack(0.6)
    model.set_mode(Mode.DISCHARGE)
    for _ in range(600):
        model.step(0.5)
    assert model.state_of_charge < 0.6 - 0.03
    assert model.gauge.soc == pytest.approx(model.state_of_charge, abs=1e-5)


def test_a_cut_off_other_than_the_voltage_does_not_snap_the_counter_to_0():
    """A discharge beyond the pack's maximum current cuts it off (EMPTY, over-current) at 60 %: the counter keeps
    60 %; only the cut-off voltage is its empty (then 0 %)."""
    model = counter_pack(0.6)
    model.step(1.0, current_a=-2.0 * model.params.max_discharge_current_a)
    assert model.status.name == 'EMPTY' and model.cut_off.name == 'OVER_CURRENT'
    assert model.gauge.soc == pytest.approx(0.6, abs=1e-3)
