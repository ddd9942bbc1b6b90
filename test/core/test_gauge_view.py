"""What a robot reads is the gauge's view, from the configured start (issue 33, items 2-5, and the gauge's
Low items), through core/battery.py as both front ends use it. No ROS: a clock of the test's own."""
import re
from pathlib import Path
from types import SimpleNamespace

import pytest

from battery_simulator.core.battery import Battery
from battery_simulator.core.battery_states import Mode, Status
from battery_simulator.core.config_files import from_mapping, preset, preset_names
from battery_simulator.core.diagnostics import battery_values
from battery_simulator.core.pack import make_model
from battery_simulator.core.status_codes import FAULTS

AGED = 'lg_hg2_7s4p_aged'


class Clock:
    def __init__(self):
        self.now = 0.0

    def __call__(self):
        return self.now


def battery(params, percentage=100.0, charging=False):
    clock = Clock()
    return Battery(params, percentage, charging, clock=clock), clock


def run(battery_, clock, seconds, update_s=10.0):
    """Updates every ``update_s`` for ``seconds``; the last Update."""
    end = clock.now + seconds
    while clock.now < end:
        clock.now += update_s
        update = battery_.update()
    return update


def message(record):
    """A battery_simulator/BatterySimState as the front ends fill it (the fields by name)."""
    return SimpleNamespace(battery=SimpleNamespace(**record.battery_fields()), **record.sim_fields())


# -- item 2: every shipped preset starts at 0, 50 and 100 % ------------------------------------------

@pytest.mark.parametrize('name', preset_names())
@pytest.mark.parametrize('percentage', [0.0, 50.0, 100.0])
def test_every_preset_starts_at_0_50_and_100_percent(name, percentage):
    """On main lg_hg2_7s4p_aged raised at 100 % ("gauge at 102.0 %": its initial_error is +2 points): the
    default of sim.launch, fleet.launch and battery_replay.py, a crash loop under respawn."""
    params = preset(name)
    battery_, clock = battery(params, percentage)
    record = run(battery_, clock, 1.0, update_s=1.0).record
    error = (params.gauge or {}).get('initial_error', 0.0)
    expected = min(100.0, max(0.0, percentage + error))
    assert record.percentage == pytest.approx(expected / 100.0, abs=0.002), (name, record.percentage)
    assert record.snapshot.true_percentage == pytest.approx(percentage, abs=0.2)


def test_a_gauges_start_error_is_clamped_to_0_100():
    gauge = {'model': 'coulomb_counter', 'initial_error': 10.0}
    assert make_model(from_mapping({'preset': 'lg_hg2_cell', 'gauge': gauge}), 0.95).snapshot().percentage == 100.0
    gauge['initial_error'] = -10.0
    assert make_model(from_mapping({'preset': 'lg_hg2_cell', 'gauge': gauge}), 0.05).snapshot().percentage == 0.0


# -- item 3: capacity_error against the pack's true capacity ---------------------------------------

def test_the_aged_gauge_believes_6_percent_more_than_the_aged_pack_holds():
    """300 cycles at 2e-4: 94 % of 11.124 Ah = 10.457 Ah, less the spread: at 50 % the weakest group's
    capacity (Q_out + Q_in = 0.5 C_min + 0.5 C_min); 6 % high (on main 11.79 Ah: 6 % above the design
    capacity, the ageing counted twice, 12.8 % above the truth)."""
    model = make_model(preset(AGED), 0.5)
    s = model.snapshot()
    weakest_ah = min(g.capacity_ah for g in model.groups)
    assert weakest_ah < 11.124 * (1.0 - 300 * 2e-4)
    assert model.capacity_ah == pytest.approx(weakest_ah, rel=1e-12)
    assert s.capacity_ah == pytest.approx(model.capacity_ah * 1.06, rel=1e-12)
    assert s.capacity_ah < s.design_capacity_ah, (s.capacity_ah, s.design_capacity_ah)


# -- item 4: the time remaining is the gauge's --------------------------------------------------------

def test_the_time_remaining_in_the_record_and_the_diagnostics_is_the_gauges():
    """A gauge 20 points low: discharging at 3 A, the time to empty is its charge over 3 A (on main: the
    truth's, beside the gauge's charge in the same message)."""
    params = from_mapping({'preset': 'lg_hg2_7s4p', 'gauge': {'model': 'coulomb_counter', 'initial_error': -20.0}})
    battery_, clock = battery(params, 80.0)
    record = run(battery_, clock, 60.0).record
    fields, sim = record.battery_fields(), record.sim_fields()
    assert fields['percentage'] < record.snapshot.true_percentage / 100.0 - 0.19
    assert fields['current'] == pytest.approx(-3.0)
    assert sim['time_remaining_s'] == pytest.approx(fields['charge'] / 3.0 * 3600.0, rel=1e-9)
    shown = dict(battery_values(message(record)))['Time Remaining (min)']
    assert shown == '%.1f' % (fields['charge'] / 3.0 * 60.0), shown
    battery_.set_mode(Mode.CHARGE, 'test')
    record = run(battery_, clock, 60.0).record
    fields, sim = record.battery_fields(), record.sim_fields()
    assert fields['current'] == pytest.approx(5.0)
    assert sim['time_remaining_s'] == pytest.approx((fields['capacity'] - fields['charge']) / 5.0 * 3600.0,
                                                    rel=1e-9)


# -- item 5: reset restores the configured start exactly ---------------------------------------------

def test_reset_restores_the_groups_offsets_the_gauges_start_error_and_the_cycle_count():
    """On main reset put every group at the start level (their offsets lost), the gauge at the truth (its
    initial error lost) and kept the groups' cycle count."""
    params = from_mapping({'preset': 'lg_hg2_cell', 'cells_series': 3,
                           'groups': [{'initial_soc_offset': -0.05}, {}, {'initial_soc_offset': 0.03}],
                           'gauge': {'model': 'coulomb_counter', 'initial_error': -4.0, 'current_offset_a': 0.1}})
    fresh = Battery(params, 70.0, clock=Clock()).model.export_state()
    battery_, clock = battery(params, 70.0)
    run(battery_, clock, 3600.0, update_s=60.0)
    assert battery_.record().snapshot.cycle_count > 0.3
    battery_.reset()
    assert battery_.model.export_state() == fresh
    s = battery_.record().snapshot
    # the groups at 0.65, 0.70, 0.73: Q_out = 0.65 C, Q_in = 0.27 C, so 0.65 / 0.92; the gauge 4 points below
    assert s.true_percentage == pytest.approx(100.0 * 0.65 / 0.92, abs=1e-9)
    assert s.percentage == pytest.approx(100.0 * 0.65 / 0.92 - 4.0, abs=1e-9)
    assert s.cycle_count == 0.0 and s.status is Status.DISCHARGING


def test_reset_keeps_the_mode_and_the_payload_loads():
    battery_, clock = battery(preset('lg_hg2_7s4p'), 60.0)
    battery_.set_load('arm', 20.0)
    battery_.set_mode(Mode.CHARGE, 'test')
    battery_.reset()
    assert battery_.mode is Mode.CHARGE and battery_.model.extra_power_w == 20.0


# -- the gauge counts the pack's current; the deadband ----------------------------------------------

def test_the_gauge_of_a_parallel_pack_counts_the_packs_current():
    """7S4P at 3 A for an hour with a +2 % gain error: 3.06 Ah counted of the 11.124 Ah believed (a gauge
    counting one cell's 0.75 A would count 0.765 Ah)."""
    params = from_mapping({'preset': 'lg_hg2_7s4p', 'gauge': {'model': 'coulomb_counter', 'current_gain_error': 0.02}})
    model = make_model(params, 0.9, mode=Mode.DISCHARGE)
    for _ in range(360):
        model.step(10.0)
    assert model.snapshot().percentage == pytest.approx(90.0 - 100.0 * 3.06 / 11.124, abs=1e-9)


def test_a_gauge_does_not_count_its_offset_while_no_current_flows():
    """The aged preset's 20 mA offset: on main +0.17 %/h at Empty, and a -20 mA offset pulled a Full pack on
    the dock below 100 %. A real gauge's deadband (by default just above the offset) stops it."""
    empty = make_model(preset(AGED), 0.02, mode=Mode.DISCHARGE)
    while empty.status is not Status.EMPTY:
        empty.step(10.0)
    assert empty.snapshot().percentage == 0.0
    for _ in range(360):
        empty.step(10.0)
    assert empty.snapshot().percentage == 0.0, 'an hour at Empty'
    params = from_mapping({'preset': AGED, 'gauge': dict(preset(AGED).gauge, current_offset_a=-0.02)})
    full = make_model(params, 0.99, mode=Mode.CHARGE)
    while full.status is not Status.FULL:
        full.step(10.0)
    assert full.snapshot().percentage == 100.0
    for _ in range(360):
        full.step(10.0)
    assert full.snapshot().percentage == 100.0, 'an hour Full on the charger'


def test_a_current_beyond_the_deadband_is_counted_and_one_within_is_not():
    params = from_mapping({'preset': 'lg_hg2_cell', 'capacity_fade_per_cycle': 0.0,
                           'gauge': {'model': 'coulomb_counter', 'deadband_a': 0.05}})
    model = make_model(params, 0.5, mode=Mode.IDLE)
    model.step(3600.0, current_a=-0.04)
    assert model.snapshot().percentage == 50.0
    model.step(3600.0, current_a=-0.06)
    assert model.snapshot().percentage == pytest.approx(50.0 - 100.0 * 0.06 / 2.781, abs=1e-9)


# -- InjectFault.srv ---------------------------------------------------------------------------------

def test_the_inject_fault_service_comment_names_every_fault():
    srv = (Path(__file__).resolve().parents[2] / 'srv' / 'InjectFault.srv').read_text()
    comment = ' '.join(line for line in srv.splitlines() if line.startswith('#'))
    named = set(re.findall(r'[a-z]+_[a-z_]+|overheat', comment))
    assert set(FAULTS) <= named, sorted(set(FAULTS) - named)
