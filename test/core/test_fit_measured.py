"""battery_fit on measured logs (issue 39): small measured logs in test/data/measured/ (README.md there gives
their sources and citations), each fitted on its first 60 % and scored on the rest through battery_replay's
function, in mV per true series cell. Plus the units, the idle term and a user's files."""
import gzip
import os
import shutil
import subprocess
import sys

import numpy as np
import pytest
import yaml

import fit_logs
from battery_simulator.cli import fit as fit_cli
from battery_simulator.core.fit.circuit import counted_charge_ah

DATA = os.path.join(os.path.dirname(os.path.abspath(__file__)), '..', 'data', 'measured')
I3 = os.path.join(DATA, 'bmw_i3_TripA01.csv.gz')
I3_WINTER = os.path.join(DATA, 'bmw_i3_TripB06.csv.gz')
A123 = os.path.join(DATA, 'calce_a123_dst_20C.csv.gz')
#: the same cell's other dynamic cycles, each a CC-CV charge from 2.0 V and the cycle to 2.0 V
A123_US06 = os.path.join(DATA, 'calce_a123_us06.csv.gz')
A123_FUDS = os.path.join(DATA, 'calce_a123_fuds.csv.gz')


def _columns(path):
    with gzip.open(path, 'rt') as stream:
        return np.genfromtxt(stream, delimiter=',', names=True)


def test_bmw_i3_drive_96_cells_bms_capacity_and_temperature(tmp_path):
    data = _columns(I3)
    charge = np.concatenate([[0.0], np.cumsum(data['current'][:-1] * np.diff(data['time']))]) / 3600.0
    bms_capacity = np.polyfit(charge, data['percentage'], 1)[0] ** -1   # the BMS's coulomb count, whole drive
    figures = fit_logs.fit_and_score(I3, str(tmp_path), cells=96)
    assert figures['cells_series'] == 96, figures['report']
    assert figures['capacity_ah'] == pytest.approx(bms_capacity, rel=0.05), 'capacity %.1f Ah, BMS %.1f Ah' % (
        figures['capacity_ah'], bms_capacity)
    assert figures['temperature_k'] <= 5.0, 'the model\'s temperature %.1f K from the logged' % figures['temperature_k']
    assert figures['held_mv'] <= 15.0, 'held out %.1f mV per cell (at most 15)' % figures['held_mv']
    assert 'surface_soc_lag_s' not in open(figures['config']).read()   # an LFP cell's near-empty lag only


def test_usual_pack_layout_only_where_the_ocv_level_cannot_tell():
    """Counts within 5 % of the best fit of the OCV level are not told apart by a pack's voltage: the one with
    the most module layouts is taken. Below 21 cells no other count lies within 5 %: the data decide alone."""
    from battery_simulator.core.fit.series import usual_count
    assert usual_count(list(range(85, 110)), 99) == 96
    assert usual_count(list(range(85, 110)), 92) == 96
    assert usual_count(list(range(85, 120)), 110) == 108
    assert usual_count(list(range(20, 30)), 23) == 24
    assert all(usual_count(list(range(1, 21)), n) == n for n in range(1, 21))
    assert usual_count(list(range(89, 96)), 93) == 90   # 96 outside what the voltage allows: not taken


@pytest.mark.parametrize('name, fitted_best', [('bmw_i3_TripB06.csv.gz', 97), ('bmw_i3_TripB13.csv.gz', 99)])
def test_bmw_i3_series_count_96_with_the_runner_up_said(name, fitted_best):
    """The i3's cells sit up to 5 % above LG HG2's OCV at the BMS's percentage (their own chemistry): the level
    alone put B06 at 97 cells and B13 (a drive at 56 % SOC) at 99, 96 at 38 times the pack RMSE. The
    count within the cells' level spread that packs are built of is taken, the best fit named in a warning.
    Among LG HG2 and LFP: the i3's own cell (bmw_i3_60ah_cell, fitted to these drives) fits B06's level at 96."""
    from battery_simulator.core.config_files import preset
    from battery_simulator.core.fit.conventions import prepare, split_at_gaps
    from battery_simulator.core.fit.known import fit_mask, known_charge
    from battery_simulator.core.fit.log_reader import read_log
    from battery_simulator.core.fit.series import series_count
    candidates = [(name, preset(name)) for name in ('lg_hg2_cell', 'a123_lfp_cell')]
    logs = split_at_gaps(prepare(read_log(os.path.join(DATA, name)), candidates[0][1].cmd_vel_timeout_s))
    masks = [fit_mask(log, 0.4) for log in logs]
    warnings = []
    count, why, chemistry, _, moved = series_count(logs, masks, candidates, known_charge(logs, masks), None, None,
                                            lambda *_: None, warnings)
    assert (count, chemistry, moved) == (96, 'lg_hg2_cell', True), why
    assert any('best fit of the OCV level, %d cells' % fitted_best in w for w in warnings), warnings
    if name == 'bmw_i3_TripB06.csv.gz':
        candidates.append(('bmw_i3_60ah_cell', preset('bmw_i3_60ah_cell')))
        count, why, chemistry, _, moved = series_count(logs, masks, candidates, known_charge(logs, masks), None,
                                                       None, lambda *_: None, [])
        assert (count, chemistry, moved) == (96, 'bmw_i3_60ah_cell', False), why


def test_another_cell_of_the_first_s_chemistry_only_where_the_first_s_level_is_off_beyond_the_bms_spread():
    """B18 (a winter drive at 3-6 degC, 83-68 % by the BMS; none of the preset's 14): the i3's own cell reads
    22.7 mV per cell off the percentage's level, LG HG2 7.1, over three times better. A car's own cell is off
    by that much from drive to drive (median 10.9 mV, up to 48 on its 60 drives), so the i3's cell is kept:
    LG HG2 taken held out 28.9 mV per cell, the i3's 6.6. LFP's rule (three times better) is unchanged."""
    from battery_simulator.core.config_files import preset
    from battery_simulator.core.fit.conventions import prepare, split_at_gaps
    from battery_simulator.core.fit.known import fit_mask, known_charge
    from battery_simulator.core.fit.log_reader import read_log
    from battery_simulator.core.fit.series import series_count
    candidates = [(name, preset(name)) for name in ('lg_hg2_cell', 'a123_lfp_cell', 'bmw_i3_60ah_cell')]
    logs = split_at_gaps(prepare(read_log(os.path.join(DATA, 'bmw_i3_TripB18.csv.gz')),
                                 candidates[0][1].cmd_vel_timeout_s))
    masks = [fit_mask(log, 0.4) for log in logs]
    count, why, chemistry, _, _ = series_count(logs, masks, candidates, known_charge(logs, masks), None, None,
                                               lambda *_: None, [])
    assert (count, chemistry) == (96, 'bmw_i3_60ah_cell'), why


def test_a_drive_the_i3_cell_preset_never_saw_is_detected_and_predicted(tmp_path):
    """bmw_i3_60ah_cell is fitted to the 14 drives in shared/; A25 (65-74 %, 20 degC) is none of them. Without
    --chemistry the i3's cell fits the fitted part's level best at the count it takes: 96S1P, held out 4.5 mV
    per cell. Over the LG HG2's shape (before the preset, and with --chemistry li-ion) 6.8 (22.3 while the slow
    pair could be slower than the fitted part lasts)."""
    path = os.path.join(DATA, 'bmw_i3_TripA25.csv.gz')
    figures = fit_logs.fit_and_score(path, str(tmp_path), cells=96)
    assert 'fitted over the bmw_i3_60ah_cell preset: 96 cells in series x 1 in parallel' in figures['report'], \
        figures['report']
    assert figures['held_mv'] <= 10.0, figures['held_mv']
    (tmp_path / 'hg2').mkdir()
    over_hg2 = fit_logs.fit_and_score(path, str(tmp_path / 'hg2'), cells=96, extra=['--chemistry', 'li-ion'])
    assert figures['held_mv'] < over_hg2['held_mv'], (figures['held_mv'], over_hg2['held_mv'])


def test_a_slow_pair_is_no_slower_than_the_fitted_part_lasts(tmp_path):
    """A22 (a summer drive at 87-76 % by the BMS; none of the preset's 14): over its 1103 s fitted the slow pair
    went to tau1 6537 +- 1800 s with R1 13 times the preset's, an integrator of the charge standing in for the
    OCV's slope, and held out 16.5 mV per cell. No longer than the fitted part lasts: 3.2 (the whole drive
    fitted finds tau1 368 s)."""
    from battery_simulator.core.config_files import load_yaml
    figures = fit_logs.fit_and_score(os.path.join(DATA, 'bmw_i3_TripA22.csv.gz'), str(tmp_path), cells=96)
    assert load_yaml(figures['config']).tau1_s <= 1103.0, figures['report']
    assert figures['held_mv'] <= 6.0, figures['held_mv']


def test_a_stretched_soc_scale_needs_the_span_a_learned_curve_needs(tmp_path):
    """The BMW i3's A14 drives 80-83 % (the BMS's): over 3 % of SOC a stretched scale of the preset's OCV fitted
    the noise (0.34 + 0.56 x, 1.0 against 2.0 mV per cell on the fitted part), and the next drive at 63-75 % was
    predicted 32.7 mV per cell off (23.7 without it). Like a learned curve it needs 5 % of SOC."""
    figures = fit_logs.fit_and_score(os.path.join(DATA, 'bmw_i3_TripA14.csv.gz'), str(tmp_path), cells=96)
    assert 'ocv_soc_scale' not in figures['report'], figures['report']
    assert figures['held_mv'] <= 5.0, figures['held_mv']


def test_a_cell_larger_than_the_first_is_tried_only_in_a_pack_that_holds_it():
    """A pack holds no less than one of its cells: the i3's 62 Ah cell is no candidate for a log whose
    capacity is unknown or smaller (LG HG2's C/20 test: 2.85 Ah), and one for the i3's 61 Ah."""
    from battery_simulator.core.config_files import preset
    from battery_simulator.core.fit.series import _holds_a_cell
    first, large = preset('lg_hg2_cell'), preset('bmw_i3_60ah_cell')
    assert _holds_a_cell(preset('a123_lfp_cell'), first, None)
    assert not _holds_a_cell(large, first, None) and not _holds_a_cell(large, first, 2.85)
    assert not _holds_a_cell(large, first, 0.85 * large.cell_capacity_ah)
    assert _holds_a_cell(large, first, 61.1)


def test_bmw_i3_at_its_usual_count_reads_the_ocv_level_from_the_percentage(tmp_path):
    """B13 (56-57 % by the BMS): 96 cells taken where the preset's level fits 99 best; at 96 the preset's
    level is 190 mV per cell low there, so the offset is read from the logged percentage: held out 8.2 mV
    per cell (99 cells before, 8.6 per true cell; at 96 without the offset the model sat 0.1-0.2 V low). Over
    LG HG2's shape (--chemistry li-ion): without it the i3's own cell is taken, whose level fits."""
    path = os.path.join(DATA, 'bmw_i3_TripB13.csv.gz')
    data = _columns(path)
    charge = np.concatenate([[0.0], np.cumsum(data['current'][:-1] * np.diff(data['time']))]) / 3600.0
    known = np.isfinite(data['percentage'])
    bms_capacity = np.polyfit(charge[known], data['percentage'][known], 1)[0] ** -1
    figures = fit_logs.fit_and_score(path, str(tmp_path), cells=96, extra=['--chemistry', 'li-ion'])
    assert figures['cells_series'] == 96, figures['report']
    assert 'voltage at the SOC the logged percentage gives' in figures['report'], figures['report']
    assert figures['capacity_ah'] == pytest.approx(bms_capacity, rel=0.05)
    assert figures['temperature_k'] <= 5.0 and figures['held_mv'] <= 15.0, (figures['temperature_k'],
                                                                            figures['held_mv'])


def test_a_cut_off_pins_soc_0_where_no_full_charge_pins_soc_1():
    """LG HG2's C/20 test (Kollmeyer): a discharge from 4.176 V to 2.8 V, a rest, the charge back; the fitted
    part has no CC-CV charge's end and no percentage. The discharge's end at its knee is SOC 0, so each start
    is the charge counted to it over the capacity: a learned curve may not stretch the SOC scale (before: the
    fit started at SOC 0.918 with 3.12 Ah, held out 52.2 mV against the unfitted preset's 34.7; now 0.975,
    2.85 Ah, 35.7 mV: docs/fit.md). A discharge stopped at half charge (no knee) pins nothing."""
    from battery_simulator.core.fit.conventions import prepare
    from battery_simulator.core.fit.electrical import fit_electrical
    from battery_simulator.core.fit.circuit import Chemistry
    from battery_simulator.core.fit.known import fit_mask, known_charge, preset_temperature
    from battery_simulator.core.fit.log_reader import read_log
    from battery_simulator.core.config_files import preset
    log = prepare(read_log(os.path.join(DATA, 'lg_hg2_549_C20DisCh.csv.gz')))
    masks = [fit_mask(log, 0.4)]
    known = known_charge([log], masks)
    charge = counted_charge_ah(log)
    assert known.empty_at is not None and charge[known.empty_at[0]] == pytest.approx(charge.min(), abs=0.01)
    chemistry = Chemistry(preset('lg_hg2_cell'))
    result = fit_electrical([log], masks, chemistry, 1, 1, [preset_temperature(log, chemistry)], True, None,
                            max_evaluations=4, known=known)
    assert result.soc0[0] == pytest.approx(-charge[known.empty_at[0]] / result.capacity_ah, abs=1e-6)
    half = masks[0] & (np.arange(len(log.time_s)) < int(np.argmin(charge)) - 120)   # 2 h before empty
    assert known_charge([log], [half]).empty_at is None


def test_lg_hg2_c20_charge_back_predicted_with_the_fitted_coulombic_efficiency(tmp_path):
    """LG HG2's C/20 test (Kollmeyer): the cycler counted 2.78 Ah out to 2.8 V and 2.97 Ah back in to the same
    4.19 V at rest. The fitted part (the discharge, the rest, 4 h of the charge) has a lasting charge beside the
    discharge and no percentage: the coulombic efficiency is fitted beside the learned curve. Before (0.999
    kept): the charge held out ran 25-60 mV above the cell, 35.7 mV per cell against the unfitted preset's
    34.7; the issue asks at least 30 % better than the preset. And the learned curve's SOC 0 sat at 2.909 V, the
    model's cut-off with it, where the cycler discharged on to 2.80 V: the model stopped 1 % of SOC early."""
    from battery_simulator.core.config_files import load_yaml
    path = os.path.join(DATA, 'lg_hg2_549_C20DisCh.csv.gz')
    figures = fit_logs.fit_and_score(path, str(tmp_path), cells=1)
    preset_mv = fit_logs.preset_rmse(path, 'lg_hg2_cell', 1, 1, holdout=0.4)
    assert figures['held_mv'] <= 0.7 * preset_mv, (figures['held_mv'], preset_mv, figures['report'])
    assert 'coulombic_efficiency' in figures['report'], figures['report']
    # the cycler discharged to 2.80 V: the model's cut-off no higher (before: 2.909 V, the model stopped early)
    assert load_yaml(figures['config']).cell_cutoff_voltage_v <= 2.8 + 1e-3


def _cycling_log(path, params, cycles=4, dt=10.0, seed=3):
    """A cycler's log of one cell (no percentage): discharges to the cut-off at 1C and C/2 in turn, each
    followed by a rest, a CC-CV charge and a rest, the voltage and current with a cycler's noise."""
    import random
    from battery_simulator.core.battery_model import BatteryModel
    from battery_simulator.core.battery_states import Mode
    model = BatteryModel(params, state_of_charge=1.0, mode=Mode.IDLE)
    rng, rows, now = random.Random(seed), [], 0.0

    def run(mode, steps, current=None, until=None):
        nonlocal now
        model.set_mode(mode)
        for _ in range(steps):
            snapshot = model.snapshot()
            rows.append((now, snapshot.voltage_v + rng.gauss(0, 0.002), snapshot.current_a + rng.gauss(0, 0.005),
                         snapshot.temperature_c))
            model.step(dt, current_a=current) if current is not None else model.step(dt)
            now += dt
            if until and model.status.name == until:
                break
    for cycle in range(cycles):
        run(Mode.DISCHARGE, 10 ** 6, -params.cell_capacity_ah / (1 + cycle % 2), 'EMPTY')
        run(Mode.IDLE, 60, 0.0)
        run(Mode.CHARGE, int(4 * 3600 / dt), None, 'FULL')
        run(Mode.IDLE, 60, 0.0)
    np.savetxt(path, np.array(rows), delimiter=',', header='time,voltage,current,temperature', comments='',
               fmt='%.5f')


def test_a_cycling_log_with_a_coulombic_efficiency_below_one_is_fitted(tmp_path):
    """A cell of another chemistry than the preset's (its OCV LG HG2's plus a 70 mV wave) cycled by a cycler that
    counts 3 % more charge in than out (coulombic efficiency 0.97; Kollmeyer's HG2 at C/20: 2.97 Ah in after
    2.78 Ah out), no percentage. Before, the preset's 0.999 was kept: the charges' SOC ran ahead, held out
    70.8 mV per cell against the unfitted preset's 127.3. Now the efficiency is fitted beside the learned
    curve: 0.966, held out 25.9."""
    from battery_simulator.core.config_files import from_mapping, load_yaml
    params = from_mapping(dict({'preset': 'lg_hg2_cell', 'coulombic_efficiency': 0.97, 'charge_current_a': 1.5,
                                'cell_capacity_ah': 3.2, 'r0_ohm': 0.03, 'r1_ohm': 0.015, 'tau1_s': 200.0,
                                'r_fast_ohm': 0.008, 'tau_fast_s': 15.0, 'hysteresis_ah': 0.3},
                               **fit_logs._tables(fit_logs.MADE_UP_SOC, fit_logs.made_up_ocv)))
    path = os.path.join(str(tmp_path), 'cycling.csv')
    _cycling_log(path, params)
    figures = fit_logs.fit_and_score(path, str(tmp_path), cells=1)
    preset_mv = fit_logs.preset_rmse(path, 'lg_hg2_cell', 1, 1, holdout=0.4)
    assert figures['held_mv'] <= 0.3 * preset_mv, (figures['held_mv'], preset_mv, figures['report'])
    assert load_yaml(figures['config']).coulombic_efficiency == pytest.approx(0.97, abs=0.01)


def test_capacity_from_the_percentage_is_not_moved_by_a_stretch_it_disagrees_with():
    """The winter drive B02's first 3 minutes: its current ramps linearly from -19 to -134 A and back in 170 s
    (a gap in the source filled by interpolation: 3.6 Ah drawn while the BMS's percentage moved 1.8 %). A
    least-squares line of the percentage on the counted charge gave 105.9 Ah over the fitted part (the car's
    summer drives: 61.7); the median of the slopes between pairs of samples is not moved by such a stretch.
    Here the same put into B06 (100 A more drawn over its first 2 minutes)."""
    from battery_simulator.core.fit.conventions import prepare
    from battery_simulator.core.fit.known import fit_mask, known_charge
    from battery_simulator.core.fit.log_reader import read_log
    log = prepare(read_log(I3_WINTER))
    masks = [fit_mask(log, 0.4)]
    clean = known_charge([log], masks).capacity_ah
    assert clean == pytest.approx(61.7, rel=0.05)
    early = (log.time_s > 20.0) & (log.time_s < 140.0)
    log.current_a = np.where(early, log.current_a - 100.0, log.current_a)
    assert known_charge([log], masks).capacity_ah == pytest.approx(clean, rel=0.05)


def test_a_gap_filled_by_interpolation_is_left_out_of_the_fit(tmp_path):
    """The i3 source fills gaps by linear interpolation (B02's first minutes: voltage and current straight in
    time from 386.0 V, -28.8 A to 370.1 V, -139.6 A over 160 s; a measured signal's noise never is). Put into
    the winter drive B06 (300-600 s, in its fitted part): before, the fit took the filled voltages and the
    charge counted across them for measurements: 46.3 Ah, held out 36.2 mV per cell (5.0 without the gap);
    now those samples are left out (said in the report) and the percentage's slope is read within the
    stretches on either side: 61.2 Ah, 11.0 mV."""
    data = _columns(I3_WINTER)
    clean = np.array(data, copy=True)
    t = data['time']
    k0, k1 = np.searchsorted(t, 300.0), np.searchsorted(t, 600.0)
    for column in ('voltage', 'current'):
        ends = [data[column][k0], data[column][k1]]
        data[column][k0:k1 + 1] = np.round(np.interp(t[k0:k1 + 1], [t[k0], t[k1]], ends), 2)
    assert not np.array_equal(clean['voltage'], data['voltage'])
    path = os.path.join(str(tmp_path), 'b06_filled.csv')
    np.savetxt(path, data, delimiter=',', header=','.join(data.dtype.names), comments='', fmt='%.6g')
    figures = fit_logs.fit_and_score(path, str(tmp_path), cells=96)
    assert 'a gap in the source filled by interpolation' in figures['report'], figures['report']
    assert figures['capacity_ah'] == pytest.approx(61.7, rel=0.05), figures['capacity_ah']
    assert figures['held_mv'] <= 15.0, figures['held_mv']


def test_a_rest_does_not_run_across_samples_left_out():
    """Two standstills of 100 s on either side of a filled gap are no 120 s rest (before: the samples left
    out were skipped and the two joined into one of 300 s, and an OCV offset was read from it)."""
    from types import SimpleNamespace
    from battery_simulator.core.fit.known import log_has_rest
    t = np.arange(0.0, 400.0, 1.0)
    i = np.where((t >= 100.0) & (t < 200.0) | (t >= 300.0), -20.0, -0.01)
    log = SimpleNamespace(time_s=t, current_a=i)
    kept = ~((t >= 100.0) & (t < 200.0))
    assert not log_has_rest(log, kept)
    assert not log_has_rest(log, np.ones(len(t), dtype=bool))   # still 0-99 and 200-299: 99 s each
    longer = SimpleNamespace(time_s=t, current_a=np.where(t >= 300.0, -20.0, -0.01))
    assert log_has_rest(longer, np.ones(len(t), dtype=bool))


def test_a_stretched_ocv_scale_never_cuts_off_what_the_log_went_through(tmp_path):
    """The winter drive B06: the preset's OCV on a stretched SOC scale (0.497 + 0.375 x) put SOC 0 at 3.738 V
    per cell while the fitted part went down to 3.528 V: the replay's model disconnected (fitted part 56.5 mV
    per cell, held out 17.4). That scale is not taken: 4.0 and 4.2 mV."""
    figures = fit_logs.fit_and_score(I3_WINTER, str(tmp_path), cells=96)
    assert 'go below the cut-off' not in figures['report'], figures['report']
    assert figures['fitted_mv'] <= 10.0 and figures['held_mv'] <= 15.0, (figures['fitted_mv'], figures['held_mv'])


def test_a123_lfp_cell_detected_with_its_capacity(tmp_path):
    data = _columns(A123)
    charge = np.concatenate([[0.0], np.cumsum(data['current'][:-1] * np.diff(data['time']))]) / 3600.0
    full = int(np.argmax(charge))
    measured_capacity = charge[full] - charge[-1]   # from the CC-CV charge's end to 2.0 V
    figures = fit_logs.fit_and_score(A123, str(tmp_path), cells=1, predict=[A123_US06, A123_FUDS])
    assert 'chemistry                      lfp' in figures['report'], figures['report']
    assert 'preset: a123_lfp_cell' in open(figures['config']).read()
    assert figures['cells_series'] == 1
    assert figures['capacity_ah'] == pytest.approx(measured_capacity, rel=0.05), \
        'capacity %.3f Ah, measured %.3f Ah' % (figures['capacity_ah'], measured_capacity)
    assert 'cutoff_soc' in figures['report'], figures['report']   # the 1C cut-off is not the table's SOC 0
    config = open(figures['config']).read()
    assert 'surface_soc_lag_s: ' in config and 'tau_surface_s: ' in config, config   # the 1C cut-off and its rest
    # the charger's constant voltage as logged (3.6013 V), above the OCV table's top (3.594 V), where it was cut
    fitted_params = yaml.safe_load(config)
    first_60 = data['time'] <= data['time'][0] + 0.6 * (data['time'][-1] - data['time'][0])
    tapering = first_60 & (data['current'] > 0.05) & (data['current'] < 0.5)   # the CV taper (CC at 1.1 A)
    logged_top = float(np.max(data['voltage'][tapering]))
    assert fitted_params['cell_charge_voltage_v'] == pytest.approx(logged_top, abs=1e-4)
    assert fitted_params['cell_charge_voltage_v'] > fitted_params['ocv_voltage_v'][-1]
    assert figures['fitted_mv'] <= LFP_FITTED_MV, 'fitted part %.1f mV per cell' % figures['fitted_mv']
    assert figures['held_mv'] <= LFP_HELD_MV, 'held out %.1f mV per cell' % figures['held_mv']
    us06, fuds = figures['predicted_mv']   # each replayed whole from the SOC its first voltage gives
    assert us06 <= LFP_US06_MV and fuds <= LFP_FUDS_MV, 'predicted US06 %.1f, FUDS %.1f mV per cell' % (us06, fuds)


#: the DST's last 40 % (down to 2.0 V) replayed with the logged current: 42.7 mV per cell measured (65.3 while the
#: replay held each row's current until the next row, one sample late for this cycler; see docs/fit.md)
#: 30.0 since the preset's charge branch is tried at half its gap (its model charged at 3.6 V by 70 % SOC, a
#: replay's charge stopped short: 42.7); the other two cycles predicted: US06 30.1 (39.4), FUDS 70.1 (94.8).
#: 26.5, US06 21.7, FUDS 54.9 since the CC-CV charge's end is where its taper ends (not where it fell below 2 %
#: of the log's largest current: 0.0036 Ah short) and the LFP table's SOC 0 lies below a loaded cut-off (the
#: 1C cut-off pinned at the SOC of the voltage its rest relaxed to: 1.063 Ah from full to the table's SOC 0);
#: 21.4, US06 16.2, FUDS 54.2 since the LFP charge branch near full is what the CC-CV taper holds (0.117-0.150 V
#: above the discharge branch at 95-99 % SOC, before 0.025-0.01 V: the fitted part 35.4 -> 21.1)
#: 10.5, US06 15.5, FUDS 34.9 (the fitted part 15.7) since the OCV is read at a surface SOC lagging the counted one
#: (surface_soc_lag_s 101 s, tau_surface_s 301 s: the 1C cut-off comes 1-2 % of the charge before FUDS's);
#: 13.9, US06 17.3, FUDS 27.5 (the fitted part 16.2) since the charge voltage is the log's highest (3.6013 V), not
#: cut to the OCV table's top (3.594 V): FUDS within the issue's 30 mV per cell
LFP_FITTED_MV, LFP_HELD_MV = 18.0, 15.5
LFP_US06_MV, LFP_FUDS_MV = 19.5, 30.0


@pytest.mark.parametrize('fitted, held_mv, predicted_mv', [
    (A123_US06, 21.0, {A123: 55.0, A123_FUDS: 42.0}),
    (A123_FUDS, 40.0, {A123: 53.0, A123_US06: 28.0})])
def test_a123_one_cycle_fitted_the_other_two_predicted(fitted, held_mv, predicted_mv, tmp_path):
    """The same cell's US06 (or FUDS) log, a CC-CV charge and the cycle to 2.0 V, fitted on its first 60 %, the
    other two logs predicted whole. Fitted on US06, the slow pair went to its bound (tau1 20000 s, R1 0.56 ohm,
    the OCV 59 mV down: a charge integrator in place of the flat OCV's slope) and held out 440 mV per cell; the
    pair the log can time fits within 1 % (docs/fit.md): US06 fitted 34.7 held out, DST 55.1, FUDS 46.0
    (before this session's LFP changes 39.7, 56.0, 84.0); FUDS fitted 36.3, DST 49.0, US06 26.0 (77.3, 49.9,
    25.0). With the charge branch near full the CC-CV taper holds: US06 fitted 15.8, DST 51.0, FUDS 37.8;
    FUDS fitted 37.6, DST 50.4, US06 22.8. With the log's highest voltage as the charge voltage (3.6013 V, not
    the OCV table's top): US06 fitted 19.0, DST 51.0, FUDS 37.8; FUDS fitted 30.1, DST 50.8, US06 25.5."""
    others = list(predicted_mv)
    figures = fit_logs.fit_and_score(fitted, str(tmp_path), cells=1, predict=others)
    assert 'chemistry                      lfp' in figures['report'], figures['report']
    # no cut-off in the fitted 60 %: a surface SOC's lag cannot be told there (set by hand it made these worse)
    assert 'surface_soc_lag_s' not in open(figures['config']).read()
    assert figures['held_mv'] <= held_mv, 'held out %.1f mV per cell' % figures['held_mv']
    for other, value in zip(others, figures['predicted_mv']):
        assert value <= predicted_mv[other], '%s predicted %.1f mV per cell' % (os.path.basename(other), value)


def test_a_cc_cv_charge_ends_where_its_taper_ends():
    """The A123 cell's taper falls below 2 % of the log's largest current (0.066 A) before its charger stops
    at 0.055 A: full is the taper's last charging sample, 0.0036 Ah later (before: the first below 2 %)."""
    from battery_simulator.core.fit.conventions import prepare
    from battery_simulator.core.fit.known import fit_mask, known_charge
    from battery_simulator.core.fit.log_reader import read_log
    log = prepare(read_log(A123))
    known = known_charge([log], [fit_mask(log, 0.4)])
    full = known.full_at[0]
    charge = counted_charge_ah(log)
    assert 0.0 < log.current_a[full] < 0.066 and log.current_a[full + 1] <= 0.0, log.current_a[full - 2:full + 3]
    assert charge[full] == pytest.approx(charge.max(), abs=1e-4)


def test_an_lfp_cut_off_under_load_is_pinned_at_the_soc_its_rest_shows():
    """LFP's table puts SOC 0 (2.0 V) below where a loaded cut-off stops (the A123 cell relaxes to 2.59 V within
    2 minutes of its 1C cut-off): the capacity from full to that cut-off is 1 - that SOC of the capacity, that
    SOC taken at most 4 % (a cold cell's cut-off relaxes higher). A Li-ion preset's capacity is left as counted."""
    from battery_simulator.core.config_files import preset
    from battery_simulator.core.fit.known import CUTOFF_SOC_MAX, Known, pinned_at_dynamic_cutoff
    lfp = preset('a123_lfp_cell')
    fitted = {}
    known = pinned_at_dynamic_cutoff(Known(capacity_ah=1.0, empty_rest_v=2.6, full_at=[5]), lfp, 1, fitted)
    soc = fitted['cutoff_soc'].value
    assert 0.01 < soc < 0.05 and known.capacity_ah == pytest.approx(1.0 / (1.0 - soc))
    assert np.interp(soc, lfp.ocv_soc, lfp.ocv_voltage_v) == pytest.approx(2.6, abs=1e-3)
    cold = pinned_at_dynamic_cutoff(Known(capacity_ah=1.0, empty_rest_v=3.1, full_at=[5]), lfp, 1, {})
    assert cold.capacity_ah == pytest.approx(1.0 / (1.0 - CUTOFF_SOC_MAX))   # a cold cell's: within 4 % of counted
    for params, rest in ((preset('lg_hg2_cell'), 3.2), (lfp, None)):
        same = Known(capacity_ah=1.0, empty_rest_v=rest, full_at=[5])
        assert pinned_at_dynamic_cutoff(same, params, 1, {}) is same


def _step_log(path, measured_at_sample, period_s=1.0, r0=0.17):
    """A resistor-and-RC cell under current steps every 1-7 samples, its voltage sampled either at the same
    instant as its current (a cycler) or answering the previous row's current (the replay's convention)."""
    rng = np.random.default_rng(4)
    n = 1500
    current = np.repeat(rng.choice([-3.0, -2.0, -0.4, 0.0, 0.8], n), rng.integers(1, 8, n))[:n]
    t = np.arange(n) * period_s
    rc, volts = 0.0, []
    for k in range(n):
        flowing = current[k] if measured_at_sample else current[k - 1] if k else 0.0
        rc = rc * np.exp(-period_s / 20.0) + 0.03 * flowing * (1 - np.exp(-period_s / 20.0))
        volts.append(3.75 - 0.05 * (k / n) + r0 * flowing + rc)
    with open(path, 'w') as stream:
        stream.write('time,voltage,current\n')
        for row in zip(t, volts, current):
            stream.write('%.3f,%.5f,%.4f\n' % row)
    return str(path)


@pytest.mark.parametrize('at_sample', [True, False])
def test_when_the_current_was_measured_is_found_and_replay_follows_it(at_sample, tmp_path):
    """Issue 39 cause 6 for a cycler: the voltage of a sample answers the current of its own sample. The fit
    finds which (the voltage jumps at the current's step or one sample later), writes it as
    profile_current_timing, and battery_replay of the log's own current follows it."""
    from battery_simulator.core.fit.conventions import prepare
    from battery_simulator.core.fit.log_reader import read_log
    from battery_simulator.core.config_files import from_mapping
    from battery_simulator.core.replay import replay
    path = _step_log(tmp_path / 'steps.csv', at_sample)
    log = prepare(read_log(path))
    assert log.current_timing == ('since_previous_row' if at_sample else 'until_next_row'), log.notes
    profile = [(0.0, 'current', -1.0), (1.0, 'current', -3.0), (2.0, 'current', 0.0)]
    params = from_mapping({'preset': 'lg_hg2_cell', 'profile_current_timing': 'since_previous_row'})
    rows = list(replay(params, profile, state_of_charge=0.5))
    assert [float(r[2]) for r in rows[1:]] == [-3.0, 0.0], 'each row\'s own current, since the previous row'
    rows = list(replay(params, profile, state_of_charge=0.5, timing='until_next_row'))
    assert [float(r[2]) for r in rows[1:]] == [-1.0, -3.0], 'the default: held until the next row'
    figures = fit_logs.fit_and_score(path, str(tmp_path), cells=1, extra=['--cells-series', '1'])
    timing = 'since_previous_row' if at_sample else 'until_next_row'
    assert ('profile_current_timing: %s' % timing in open(figures['config']).read()) == at_sample, \
        open(figures['config']).read()
    if at_sample:   # the log's own timing replays it several times closer than the other
        from battery_simulator.core.config_files import load_yaml
        raw = read_log(path)
        other = list(replay(load_yaml(figures['config']), [(t, 'current', i) for t, i in zip(raw.time_s, raw.current_a)],
                            state_of_charge=0.5, timing='until_next_row'))
        other_mv = 1000.0 * float(np.sqrt(np.mean((np.array([float(r[1]) for r in other]) - raw.voltage_v) ** 2)))
        assert figures['held_mv'] < 0.3 * other_mv, (figures['held_mv'], other_mv)
    assert figures['held_mv'] < 30.0, 'held out %.1f mV: the replay should answer the log\'s own timing' % (
        figures['held_mv'])


@pytest.mark.parametrize('name', ['lg_hg2_549_Dis_0p5C.csv.gz', 'lg_hg2_549_Dis_2C.csv.gz'])
def test_a_constant_current_test_is_fitted_with_the_presets_resistances(name, tmp_path):
    """LG HG2 cells measured by another laboratory: a constant-current discharge (0.5C, 2C) has no current step
    to tell the resistances from the OCV's level. It is fitted (capacity, start, heat), the preset's resistances
    kept and said so, never refused, and predicts its held-out 40 % at least 30 % better than the unfitted
    preset (0.5C: 65.1 against 154.8 mV, 2C: 122.0 against 269.2; refused before)."""
    path = os.path.join(DATA, name)
    figures = fit_logs.fit_and_score(path, str(tmp_path), cells=1)
    assert 'r0_ohm                         the current never steps' in figures['report'], figures['report']
    from battery_simulator.core.config_files import load_yaml, preset
    assert load_yaml(figures['config']).r0_ohm == preset('lg_hg2_cell').r0_ohm
    preset_mv = fit_logs.preset_rmse(path, 'lg_hg2_cell', 1, 1, holdout=0.4)
    assert figures['held_mv'] <= 0.7 * preset_mv, 'held out %.1f mV per cell, the unfitted preset %.1f' % (
        figures['held_mv'], preset_mv)
    assert figures['capacity_ah'] == pytest.approx(3.0, rel=0.2)


# -- units, the idle term, a user's files ----------------------------------------------------------------

@pytest.fixture(scope='module')
def robot_csv(tmp_path_factory):
    params = fit_logs.robot_params()
    samples, commands = fit_logs.simulate(params, duration_s=2400.0, seed=3)
    directory = tmp_path_factory.mktemp('robot')
    path = str(directory / 'robot.csv')
    fit_logs.write_csv(path, samples, commands)
    return params, path


def _scaled(path, out, column, factor):
    lines = open(path).read().splitlines()
    header = lines[0].split(',')
    index = header.index(column)
    with open(out, 'w') as stream:
        stream.write(lines[0] + '\n')
        for line in lines[1:]:
            cells = line.split(',')
            cells[index] = '%.6f' % (float(cells[index]) * factor)
            stream.write(','.join(cells) + '\n')
    return out


@pytest.mark.parametrize('column, unit', [('current', 'milliamperes'), ('time', 'milliseconds'),
                                          ('voltage', 'millivolts')])
def test_a_log_in_the_wrong_unit_is_one_line_naming_it(column, unit, robot_csv, tmp_path, capsys):
    _, path = robot_csv
    log = _scaled(path, str(tmp_path / 'scaled.csv'), column, 1000.0)
    output = str(tmp_path / 'out.yaml')
    with pytest.raises(SystemExit) as stopped:
        fit_cli.main([log, '-o', output])
    message = str(stopped.value.code)
    assert stopped.value.code != 0 and unit in message and '\n' not in message, message
    assert not os.path.exists(output)


def test_one_idle_term_is_fitted_and_said(robot_csv, tmp_path, capsys):
    params, path = robot_csv
    output = str(tmp_path / 'out.yaml')
    fit_cli.main([path, '-o', output])
    report = capsys.readouterr().out
    assert 'one idle term' in report, report
    from battery_simulator.core.config_files import load_yaml
    fitted = load_yaml(output)
    assert (fitted.load_current_a > 0) != (fitted.load_power_w > 0), 'exactly one idle term: %g A, %g W' % (
        fitted.load_current_a, fitted.load_power_w)
    idle_w = fitted.load_current_a * 18.5 + fitted.load_power_w
    assert idle_w == pytest.approx(params.load_current_a * 18.5, rel=0.2), 'the idle draw %.1f W' % idle_w


def test_a_users_files_are_checked_before_the_fit_and_left_alone(robot_csv, tmp_path, capsys):
    _, path = robot_csv
    output = str(tmp_path / 'out.yaml')
    part = output + '.part'
    with open(part, 'w') as stream:
        stream.write('my own notes\n')
    profiles = tmp_path / 'profiles'
    profiles.mkdir()
    existing = profiles / 'profile_1_robot_csv.csv'
    existing.write_text('mine\n')
    with pytest.raises(SystemExit) as stopped:   # an existing profile: refused before the fit, nothing written
        fit_cli.main([path, '-o', output, '--profiles', str(profiles)])
    assert stopped.value.code != 0 and 'profile_1_robot_csv.csv' in str(stopped.value.code)
    assert existing.read_text() == 'mine\n' and not os.path.exists(output)
    fit_cli.main([path, '-o', output])
    assert open(part).read() == 'my own notes\n', 'a user\'s OUT.yaml.part is never written over or deleted'
    assert os.path.exists(output)
    for bad in (['-o', '/sys/out.yaml'], ['-o', output, '--profiles', '/sys/profiles'],
                ['-o', output, '--profiles', path]):
        with pytest.raises(SystemExit) as stopped:
            fit_cli.parse_arguments([path] + bad)   # the arguments, before any fit
        assert stopped.value.code == 2


def test_the_chemistry_key_selects_the_lfp_tables_and_leaves_li_ion_alone():
    from battery_simulator.core.lfp_tables import LFP_OCV_VOLTAGE_V
    from battery_simulator.core.config_files import from_mapping, preset
    from battery_simulator.core.parameter_rules import ParameterError
    hg2 = preset('lg_hg2_cell')
    assert hg2.chemistry == 'li-ion' and from_mapping({'preset': 'lg_hg2_cell'}) == hg2
    lfp = from_mapping({'preset': 'lg_hg2_cell', 'chemistry': 'lfp'})
    assert lfp.ocv_voltage_v == LFP_OCV_VOLTAGE_V and lfp.ocv_charge_voltage_v > lfp.ocv_voltage_v
    assert (lfp.cell_cutoff_voltage_v, lfp.cell_charge_voltage_v) == (2.0, 3.6)
    a123 = preset('a123_lfp_cell')
    assert a123.chemistry == 'lfp' and a123.cell_cutoff_voltage_v == 2.0
    flat = [v for s, v in zip(a123.ocv_soc, a123.ocv_voltage_v) if 0.1 <= s <= 0.9]
    assert 3.15 <= min(flat) and max(flat) <= 3.4, 'LFP\'s flat OCV: %.3f-%.3f V' % (min(flat), max(flat))
    with pytest.raises(ParameterError):
        from_mapping({'preset': 'lg_hg2_cell', 'chemistry': 'lead'})


def test_chemistry_option_lfp_is_used_as_given(tmp_path):
    cut = str(tmp_path / 'a123_start.csv')   # the 1C discharge, the charge and the DST's first cycles
    with gzip.open(A123, 'rt') as stream, open(cut, 'w') as out:
        out.writelines(line for _, line in zip(range(4000), stream))
    figures = fit_logs.fit_and_score(cut, str(tmp_path), cells=1, extra=['--chemistry', 'lfp'])
    assert 'over the a123_lfp_cell preset' in figures['report'] and 'chemistry   ' not in figures['report']


def test_cell_voltage_gives_the_series_count_and_a_per_cell_voltage_is_warned(robot_csv):
    from battery_simulator.core.fit.conventions import prepare
    from battery_simulator.core.fit.fitting import fit
    from battery_simulator.core.fit.log_reader import read_log
    from battery_simulator.core.config_files import preset
    _, path = robot_csv
    raw = read_log(path)
    raw.cell_count, raw.cell_sum_v = 5, list(raw.voltage_v)   # BatteryState.cell_voltage: 5 cells adding up
    log = prepare(raw)
    assert log.cell_count == 5
    result = fit([log], preset('lg_hg2_cell'), 'lg_hg2_cell')
    assert result.params.cells_series == 5 and 'cell_voltage' in result.fitted['cells_series'].source
    raw = read_log(path)   # the voltage field holding one cell's voltage, the cells a pack's
    raw.cell_count, raw.cell_sum_v = 5, [5 * v for v in raw.voltage_v]
    log = prepare(raw)
    assert log.cell_count == 0
    assert any('one cell\'s voltage' in note and 'cell_voltage' in note for note in log.notes), log.notes
