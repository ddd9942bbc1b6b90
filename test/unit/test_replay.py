"""The battery_replay CLI (python3 -m battery_simulator.core.replay)."""
import contextlib
import csv
import io
import subprocess
import sys
from pathlib import Path

import pytest

from battery_simulator.core.parameters import preset
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
    profile = tmp_path / 'p.csv'
    profile.write_text('time,power\n0,-20\n600,5\n1200,0\n')
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
    profile = tmp_path / 'p.csv'
    profile.write_text('time,current\n0,-1\n1,-1\n')
    result = run_cli(profile, '--soc', '80')
    assert result.returncode == 2 and '[0, 1]' in result.stderr


def test_empty_profile_is_rejected(tmp_path):
    profile = tmp_path / 'p.csv'
    profile.write_text('time,current\n')
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
    profile = tmp_path / 'p.csv'
    profile.write_text('time,current\n0,-1\n1,-1\n')
    result = run_cli(profile, '--max-step', step)
    assert result.returncode == 2 and '--max-step' in result.stderr and 'Traceback' not in result.stderr


def test_unknown_preset_and_binary_file_get_one_line(tmp_path):
    profile = tmp_path / 'p.csv'
    profile.write_text('time,current\n0,-1\n1,-1\n')
    result = run_cli(profile, '--preset', 'turbo')
    assert result.returncode == 1 and 'turbo' in result.stderr and 'Traceback' not in result.stderr
    binary = tmp_path / 'b.csv'
    binary.write_bytes(bytes(range(256)) * 4)
    result = run_cli(binary)
    assert result.returncode == 1 and 'not a UTF-8 text CSV' in result.stderr
    assert len(result.stderr.strip().splitlines()) == 1, result.stderr


def test_unwritable_output_is_one_line(tmp_path):
    profile = tmp_path / 'p.csv'
    profile.write_text('time,current\n0,-1\n1,-1\n')
    result = run_cli(profile, '-o', tmp_path / 'no' / 'such' / 'dir.csv')
    assert result.returncode == 1 and 'cannot write' in result.stderr and 'Traceback' not in result.stderr


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
