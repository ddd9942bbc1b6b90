"""The battery_replay CLI (python3 -m battery_simulator.core.replay)."""
import contextlib
import csv
import io
import math
import os
import subprocess
import sys
from pathlib import Path

import pytest

from battery_simulator.core.battery_states import Mode
from battery_simulator.core.config_files import preset, preset_names
from battery_simulator.core.pack import make_model
from battery_simulator.core.replay import OUTPUT_COLUMNS, ProfileError, main, read_profile, replay

SOURCE = Path(__file__).resolve().parents[2] / 'src'


def run_cli(*args):
    """battery_replay.py's main() in this process (so mutation testing sees it): (returncode, stdout, stderr)."""
    stdout, stderr = io.StringIO(), io.StringIO()
    code = 0
    with contextlib.redirect_stdout(stdout), contextlib.redirect_stderr(stderr):
        try:
            main([str(a) for a in args])
        except SystemExit as exit_:
            code = exit_.code if isinstance(exit_.code, int) else 1
            if isinstance(exit_.code, str):
                print(exit_.code, file=sys.stderr)
    return subprocess.CompletedProcess(args, code, stdout.getvalue(), stderr.getvalue())


def profile_file(tmp_path, text='time,current\n0,-1\n1,-1\n'):
    path = tmp_path / 'p.csv'
    path.write_text(text)
    return path


def test_current_profile_to_stdout(tmp_path):
    profile = tmp_path / 'mission.csv'
    profile.write_text('time,current\n0,-3\n1800,-3\n3600,0\n')
    result = run_cli(profile, '--preset', 'lg_hg2_cell')
    assert result.returncode == 0, result.stderr
    rows = list(csv.DictReader(io.StringIO(result.stdout)))
    assert tuple(rows[0]) == OUTPUT_COLUMNS and len(rows) == 3
    assert float(rows[0]['soc']) == 1.0
    # 3 A for 1 h from a 2.78 Ah cell: empty (cut-off) before the hour is out
    assert rows[2]['status'] == 'EMPTY' and float(rows[2]['current']) == 0.0
    assert float(rows[1]['soc']) == pytest.approx(1 - 1.5 / 2.781, abs=0.002)
    assert float(rows[1]['current']) == -3.0


def test_power_profile_config_file_soc_and_output_file(tmp_path):
    profile = profile_file(tmp_path, 'time,power\n0,-20\n600,5\n1200,0\n')
    config = tmp_path / 'b.yaml'
    config.write_text('preset: lg_hg2_3s1p\nambient_temperature_c: 10\n')
    out = tmp_path / 'out.csv'
    result = run_cli(profile, '--config', config, '--soc', '0.5', '-o', out)
    assert result.returncode == 0, result.stderr
    rows = list(csv.DictReader(out.open()))
    assert float(rows[0]['soc']) == 0.5 and float(rows[0]['temperature']) == 10.0
    assert float(rows[1]['current']) * float(rows[1]['voltage']) == pytest.approx(-20.0, rel=0.02)
    assert rows[2]['status'] == 'CHARGING'


@pytest.mark.parametrize('text, line', [
    ('time,current\n0,-1\n10,abc\n', 'line 3'),
    ('time,current\n0,-1\n5,-2\n4,-1\n', 'line 4'),
    ('stamp,amps\n0,1\n', 'line 1'),
    ('time,current\n0,-1\n5,inf\n', 'line 3'),
])
def test_bad_profile_names_the_line(tmp_path, text, line):
    profile = tmp_path / 'bad.csv'
    profile.write_text(text)
    result = run_cli(profile)
    assert result.returncode != 0 and line in result.stderr and str(profile) in result.stderr, result.stderr
    assert 'Traceback' not in result.stderr


def test_missing_file_and_bad_soc_are_clear_errors(tmp_path):
    result = run_cli(tmp_path / 'absent.csv')
    assert result.returncode != 0 and 'cannot read' in result.stderr
    profile = profile_file(tmp_path)
    result = run_cli(profile, '--soc', '80')
    assert result.returncode == 2 and '[0, 1]' in result.stderr


def test_empty_profile_is_rejected(tmp_path):
    profile = profile_file(tmp_path, 'time,current\n')
    with pytest.raises(ProfileError, match='no data rows'):
        read_profile(profile)


def test_replay_function_yields_a_row_per_time():
    rows = list(replay(preset('lg_hg2_cell'), [(0.0, 'current', -1.0), (60.0, 'current', 0.0)]))
    assert [r[0] for r in rows] == ['0', '60']


def test_equal_times_are_a_zero_length_segment_and_a_bom_is_accepted(tmp_path):
    profile = tmp_path / 'cycler.csv'
    profile.write_bytes('\ufefftime,current\n0,-1\n10,-1\n10,-2\n20,0\n'.encode('utf-8'))
    rows = read_profile(profile)
    assert [r[0] for r in rows] == [0.0, 10.0, 10.0, 20.0]
    out = list(replay(preset('lg_hg2_cell'), rows))
    assert [r[0] for r in out] == ['0', '10', '10', '20']
    assert out[1] == out[2], 'a zero-length segment changes nothing'


def test_long_rest_and_long_load_finish_at_once(tmp_path):
    profile = tmp_path / 'rest.csv'
    profile.write_text('time,current\n0,0\n1e9,-1\n2e9,0\n')
    result = run_cli(profile, '--max-step', '0.001')
    assert result.returncode == 0, result.stderr
    rows = list(csv.DictReader(io.StringIO(result.stdout)))
    assert rows[1]['soc'] == '1.00000' and rows[2]['status'] == 'EMPTY'


@pytest.mark.parametrize('step', ['0', '-1', '0.0001', 'nan', 'inf'])
def test_max_step_below_the_floor_is_a_usage_error(tmp_path, step):
    profile = profile_file(tmp_path)
    result = run_cli(profile, '--max-step', step)
    assert result.returncode == 2 and '--max-step' in result.stderr and 'Traceback' not in result.stderr


def test_binary_file_gets_one_line(tmp_path):
    binary = tmp_path / 'b.csv'
    binary.write_bytes(bytes(range(256)) * 4)
    result = run_cli(binary)
    assert result.returncode == 1 and 'not a UTF-8 text CSV' in result.stderr
    assert len(result.stderr.strip().splitlines()) == 1, result.stderr


def test_a_closed_pipe_prints_no_traceback(tmp_path):
    profile = tmp_path / 'long.csv'
    profile.write_text('time,current\n' + ''.join('%d,-0.1\n' % t for t in range(20000)))
    result = subprocess.run('%s -m battery_simulator.core.replay %s | head -n 2' % (sys.executable, profile),
                            shell=True, capture_output=True, text=True, timeout=60,
                            env={'PYTHONPATH': str(SOURCE), 'PATH': '/usr/bin:/bin'})
    assert len(result.stdout.splitlines()) == 2
    assert 'Traceback' not in result.stderr and 'BrokenPipe' not in result.stderr, result.stderr


def test_an_empty_file_names_the_missing_header(tmp_path):
    profile = tmp_path / 'empty.csv'
    profile.write_text('')
    with pytest.raises(ProfileError, match='got nothing'):
        read_profile(profile)


HELP = '''usage: battery_replay.py [-h] [--charge A] [--preset PRESET | --config CONFIG] [--soc SOC]
                         [--max-step MAX_STEP] [-o OUTPUT] [--list-presets]
                         [profile]

Replay a CSV load profile through the battery model, or a CC-CV charge (--charge).

positional arguments:
  profile               CSV with time (s) and current (A) or power (W)

options:
  -h, --help            show this help message and exit
  --charge A            instead of a profile: a CC-CV charge at A amperes from --soc to Full
  --preset PRESET       battery preset (default lg_hg2_3s1p)
  --config CONFIG       YAML file of battery parameters
  --soc SOC             initial state of charge (the truth; a gauge starts where its config puts
                        it), 0..1 (default 1; with --charge 0): 0.2 = 20 %
  --max-step MAX_STEP   longest model step, s (default 1, at least 0.001)
  -o OUTPUT, --output OUTPUT
                        output CSV file (default: stdout)
  --list-presets        list the presets and exit
'''


def test_help_text(monkeypatch):
    monkeypatch.setenv('COLUMNS', '100')
    result = run_cli('--help')
    assert result.returncode == 0 and result.stdout == HELP


def test_usage_errors_are_one_line_naming_the_problem(tmp_path):
    result = run_cli()
    assert result.returncode == 2
    assert result.stderr.splitlines()[-1] == 'battery_replay.py: error: the profile CSV (or --charge A) is required'
    profile = profile_file(tmp_path)
    result = run_cli(profile, '--soc', '1.5')
    assert result.stderr.splitlines()[-1] == ('battery_replay.py: error: argument --soc: '
                                              '1.5 is not in [0, 1] (a fraction: 0.5 = half full)')
    result = run_cli(profile, '--max-step', '0')
    assert result.stderr.splitlines()[-1] == ('battery_replay.py: error: argument --max-step: '
                                              '0 is not a number of seconds >= 0.001')


def test_list_presets_needs_no_profile():
    result = run_cli('--list-presets')
    assert result.returncode == 0 and result.stdout == '\n'.join(preset_names()) + '\n'
    assert result.stdout.startswith('a123_lfp_cell\nbmw_i3_60ah_cell\nkobuki_4s2p\nlg_hg2_3s1p\n')


@pytest.mark.parametrize('soc, first_row', [
    ('0', ['0', '2.8000', '0.0000', '0.00000', '25.00', 'NOT_CHARGING', '2.8000', '2.8000', '0.00000', '2.7810', '']),
    # SOC 1 is where the charge ends at 50 mA (issue 40): its OCV, 4.1857 V, not the charge voltage
    ('1', ['0', '4.1857', '0.0000', '1.00000', '25.00', 'NOT_CHARGING', '4.1857', '4.1857', '1.00000', '2.7810', '']),
])
def test_soc_bounds_are_allowed_and_the_pack_starts_at_rest(tmp_path, soc, first_row):
    config = tmp_path / 'cell.yaml'
    config.write_text('preset: lg_hg2_cell\n')
    result = run_cli(profile_file(tmp_path, 'time,current\n0,0\n1,0\n'), '--config', config, '--soc', soc)
    assert result.returncode == 0, result.stderr
    assert result.stdout.splitlines()[1].split(',') == first_row


def test_one_line_errors_from_the_cli(tmp_path):
    profile = profile_file(tmp_path)
    result = run_cli(profile, '--preset', 'turbo')
    assert result.returncode == 1
    assert result.stderr == "battery_replay: parameter preset = 'turbo' is invalid: must be one of %s\n" % (
        ', '.join(preset_names()))
    out = tmp_path / 'no' / 'such' / 'dir.csv'
    result = run_cli(profile, '-o', out)
    assert result.returncode == 1
    assert result.stderr == 'battery_replay: cannot write %s: No such file or directory\n' % out
    absent = tmp_path / 'absent.csv'
    result = run_cli(absent)
    assert result.returncode == 1
    assert result.stderr == 'battery_replay: %s: cannot read: No such file or directory\n' % absent


def test_output_file_has_unix_line_ends(tmp_path):
    out = tmp_path / 'out.csv'
    assert run_cli(profile_file(tmp_path), '-o', out).returncode == 0
    assert out.read_bytes().startswith(b'time,voltage,current,soc,temperature,status,cell_voltage_min,'
                                       b'cell_voltage_max,gauge_soc,gauge_full_capacity_ah,gauge_event\n0,')
    assert b'\r' not in out.read_bytes()


def test_large_times_keep_the_exponent_format(tmp_path):
    result = run_cli(profile_file(tmp_path, 'time,current\n0,0\n1e9,0\n'))
    assert [line.split(',')[0] for line in result.stdout.splitlines()] == ['time', '0', '1e+09']


class _ClosedPipe(io.StringIO):
    """A stdout whose reader has gone."""

    def __init__(self, fd):
        super().__init__()
        self.fd = fd

    def write(self, text):
        raise BrokenPipeError

    def fileno(self):
        return self.fd


def test_a_closed_pipe_sends_the_rest_to_devnull(tmp_path, monkeypatch):
    read_end, write_end = os.pipe()
    try:
        monkeypatch.setattr(sys, 'stdout', _ClosedPipe(write_end))
        main([str(profile_file(tmp_path))])
        assert os.fstat(write_end).st_rdev == os.stat(os.devnull).st_rdev
    finally:
        os.close(read_end)
        os.close(write_end)


def stepped_by_hand(params, segments, step_s, state_of_charge=1.0, whole=()):
    """The voltages replay() should give: each (duration, kind, value) held in steps of at most step_s
    (the segments numbered in ``whole`` in one step)."""
    model = make_model(params, state_of_charge=state_of_charge, mode=Mode.IDLE)
    rows = []
    for number, (duration, kind, value) in enumerate(segments):
        steps = 1 if number in whole else max(1, int(math.ceil(duration / step_s)))
        for _ in range(steps):
            model.step(duration / steps, **{kind + ('_a' if kind == 'current' else '_w'): value})
        rows.append('%.4f' % model.voltage_v)
    return rows


def test_segments_are_cut_into_max_step_pieces():
    params = preset('lg_hg2_3s1p')
    # the 1 A charge reaches the CV phase, where the step size shows
    profile = [(0.0, 'power', -20.0), (1800.0, 'current', 1.0), (12600.0, 'power', -30.0), (13200.0, 'current', 0.0)]
    segments = [(1800.0, 'power', -20.0), (10800.0, 'current', 1.0), (600.0, 'power', -30.0)]
    fine = stepped_by_hand(params, segments, 1.0, 0.5)
    coarse = stepped_by_hand(params, segments, 600.0, 0.5)
    assert coarse != fine, 'the step size must matter for this profile'

    def voltages(**max_step):
        return [row[1] for row in list(replay(params, profile, state_of_charge=0.5, **max_step))[1:]]
    assert voltages(max_step_s=1.0) == fine and voltages(max_step_s=600.0) == coarse
    assert voltages() == fine, 'the default step is 1 s'
    charge_in_one_step = stepped_by_hand(params, segments, 1.0, 0.5, whole=(1,))
    assert charge_in_one_step[1] != fine[1], 'the charge segment must be cut into steps too'


def test_the_cli_passes_max_step_on(tmp_path):
    profile = profile_file(tmp_path, 'time,power\n0,-60\n1800,0\n')
    coarse = run_cli(profile, '--max-step', '1800').stdout.splitlines()[2].split(',')[1]
    fine = run_cli(profile).stdout.splitlines()[2].split(',')[1]
    params, segments = preset('lg_hg2_3s1p'), [(1800.0, 'power', -60.0)]
    assert coarse == stepped_by_hand(params, segments, 1800.0)[0]
    assert fine == stepped_by_hand(params, segments, 1.0)[0] != coarse


@pytest.mark.parametrize('text, error', [
    ('stamp,current\n0,1\n', '{path} line 1: the header must name a "time" column and a "current" or "power" '
                             'column, got stamp,current'),
    ('time,amps\n0,1\n', '{path} line 1: the header must name a "time" column and a "current" or "power" '
                         'column, got time,amps'),
    ('time,current\n0,-1\n10,abc\n', '{path} line 3: expected numbers in "time" and "current", got 10,abc'),
    ('time,power\n0,-1\n10\n', '{path} line 3: expected numbers in "time" and "power", got 10'),
    ('time,current\n0,-1\n5,-2\n7,-2\n6,-1\n', '{path} line 5: time 6 s is before the previous row\'s 7 s'),
    ('time,current\n0,-1\n5,nan\n', '{path} line 3: values must be finite, got 5,nan'),
    ('time,current\n', '{path}: no data rows after the header'),
    ('time,current\n0,"' + 'x' * 200000 + '"\n', '{path}: not a CSV file: field larger than field limit (131072)'),
])
def test_profile_errors_exactly(tmp_path, text, error):
    path = profile_file(tmp_path, text)
    with pytest.raises(ProfileError) as raised:
        read_profile(path)
    assert str(raised.value) == error.format(path=path)


def test_binary_profile_names_the_byte(tmp_path):
    path = tmp_path / 'b.csv'
    path.write_bytes(b'time,current\n0,-1\n\xff\n')
    with pytest.raises(ProfileError) as raised:
        read_profile(path)
    assert str(raised.value) == '%s: not a UTF-8 text CSV file (byte 18)' % path


def test_blank_rows_are_skipped_anywhere(tmp_path):
    path = profile_file(tmp_path, 'Time , Current\n0,-1\n\n,,\n 10 ,-2\n\n20,0\n')
    assert read_profile(path) == [(0.0, 'current', -1.0), (10.0, 'current', -2.0), (20.0, 'current', 0.0)]


def rows_then(error):
    """A stand-in for replay(): one row, then ``error`` (as Ctrl-C or a full disk would strike)."""
    def broken_replay(*args, **kwargs):
        yield (0.0, 4.2, 0.0, 1.0, 25.0, 'NOT_CHARGING')
        raise error
    return broken_replay


@pytest.mark.parametrize('error, code, message', [
    (KeyboardInterrupt(), 130, 'battery_replay: interrupted\n'),
    (OSError(28, 'No space left on device'), 1, 'battery_replay: cannot write {out}: No space left on device\n'),
])
def test_a_broken_replay_leaves_the_older_output_as_it_was(tmp_path, monkeypatch, error, code, message):
    out = tmp_path / 'out.csv'
    out.write_text('older results\n')
    monkeypatch.setattr('battery_simulator.core.replay.replay', rows_then(error))
    result = run_cli(profile_file(tmp_path), '-o', out)
    assert (result.returncode, result.stderr) == (code, message.format(out=out))
    assert out.read_text() == 'older results\n'
    assert sorted(p.name for p in tmp_path.iterdir()) == ['out.csv', 'p.csv'], 'no partial file left'


def test_ctrl_c_while_writing_to_stdout_exits_130_without_a_traceback(tmp_path, monkeypatch):
    monkeypatch.setattr('battery_simulator.core.replay.replay', rows_then(KeyboardInterrupt()))
    result = run_cli(profile_file(tmp_path))
    assert (result.returncode, result.stderr) == (130, 'battery_replay: interrupted\n')


def test_a_finished_replay_replaces_the_older_output(tmp_path):
    out = tmp_path / 'out.csv'
    out.write_text('older results\n')
    assert run_cli(profile_file(tmp_path), '-o', out).returncode == 0
    assert out.read_text().startswith('time,voltage,current,soc,temperature,status,')
    assert sorted(p.name for p in tmp_path.iterdir()) == ['out.csv', 'p.csv']


def test_an_output_that_is_a_folder_is_refused_and_nothing_is_left(tmp_path):
    folder = tmp_path / 'results'
    folder.mkdir()
    result = run_cli(profile_file(tmp_path), '-o', folder)
    assert (result.returncode, result.stderr) == (1, 'battery_replay: cannot write %s: Is a directory\n' % folder)
    assert sorted(p.name for p in tmp_path.iterdir()) == ['p.csv', 'results']


def test_ctrl_c_while_reading_the_profile_exits_130_without_a_traceback(tmp_path, monkeypatch):
    def interrupted(path):
        raise KeyboardInterrupt
    monkeypatch.setattr('battery_simulator.core.replay.read_profile', interrupted)
    result = run_cli(profile_file(tmp_path))
    assert (result.returncode, result.stderr) == (130, 'battery_replay: interrupted\n')


@pytest.mark.parametrize('args', [('--charge', 'abc'), ('--charge', '-1'), ('--charge', 'nan'),
                                  ('--charge', '1', '--soc', '2'), ('--max-step', 'x', 'profile.csv')])
def test_a_bad_argument_is_one_line_naming_it(args):
    result = run_cli(*args)
    assert result.returncode == 2 and result.stdout == ''
    assert result.stderr.count('\n') == 1 and result.stderr.startswith('battery_replay.py: error: argument --')
    assert '_current' not in result.stderr and '_step' not in result.stderr


def test_the_csv_has_the_cell_spread_and_what_the_gauge_read(tmp_path):
    """Part 5: cell_voltage_min / _max per series group, gauge_soc the gauge's view (soc stays the truth)."""
    config = tmp_path / 'aged.yaml'
    config.write_text('preset: lg_hg2_7s4p_aged\n')
    result = run_cli(profile_file(tmp_path, 'time,current\n0,-5\n3600,-5\n'), '--config', config, '--soc', '0.9')
    assert result.returncode == 0, result.stderr
    rows = list(csv.DictReader(io.StringIO(result.stdout)))
    last = rows[-1]
    assert float(last['cell_voltage_max']) - float(last['cell_voltage_min']) > 0.001, 'the groups differ'
    # the aged gauge starts 2 points high and believes a 6 % larger capacity: it reads more than the truth
    assert float(last['gauge_soc']) > float(last['soc']) + 0.02, last


@pytest.mark.parametrize('realistic', [False, True], ids=['lumped', 'groups_and_gauge'])
def test_a_charge_after_a_cut_off_charges_so_a_replay_can_cycle(tmp_path, realistic):
    """Issue 33 item 7: a positive current after the under-voltage cut-off charges (a charger connected
    after the cut-off, as on the running node), on a lumped pack and on a pack of groups with a gauge
    (demo.launch gauge:=realistic's config): three whole cycles."""
    source = ('--config', SOURCE.parent / 'config' / 'battery_realistic.yaml', '--soc', '0.9') if realistic \
        else ('--preset', 'lg_hg2_cell')
    rows, t = ['time,current'], 0
    for _ in range(3):   # 2 h at 3 A (the cut-off within it), then 4 h at 1.5 A (Full within it)
        rows += ['%d,-3' % t, '%d,1.5' % (t + 7200)]
        t += 7200 + 14400
    rows.append('%d,0' % t)
    result = run_cli(profile_file(tmp_path, '\n'.join(rows) + '\n'), *source)
    assert result.returncode == 0, result.stderr
    out = list(csv.DictReader(io.StringIO(result.stdout)))
    ends = [(row['status'], float(row['current']), float(row['soc']), float(row['gauge_soc'])) for row in out[1:]]
    assert [end[0] for end in ends] == ['EMPTY', 'FULL'] * 3, ends
    for status, current, soc, gauge_soc in ends:
        assert current == 0.0, ends   # no charger and no load connected between the rows' segments
        if status == 'FULL':
            assert soc == gauge_soc == 1.0, ('full, and the gauge recalibrated there', ends)
        else:
            # the gauge snapped to 0 at the cut-off and has counted its 20 mA offset at rest since
            assert soc < 0.1 and gauge_soc < (0.02 if realistic else 0.1), ('cut off', ends)
