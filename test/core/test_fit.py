"""battery_fit (contract Part 8): the fits against hand arithmetic, the round trip (simulate a robot unlike
any preset, write its log as CSV / ROS 1 bag / ROS 2 MCAP / ROS 2 sqlite3, fit, compare), the log's
conventions, and bad inputs (one line, exit status != 0, no config)."""
import csv
import math
import os
import subprocess
import sys

import numpy as np
import pytest
import yaml

import fit_logs
from battery_simulator.cli import fit as fit_cli
from battery_simulator.core.config_files import load_yaml, preset
from battery_simulator.core.fit import FitError
from battery_simulator.core.fit.circuit import rc_filter
from battery_simulator.core.fit.conventions import prepare
from battery_simulator.core.fit.fitting import fit
from battery_simulator.core.fit.log_reader import RawLog, import_rosbags, read_log
from battery_simulator.core.replay import read_profile, replay

HG2 = preset('lg_hg2_cell')
needs_rosbags = pytest.mark.skipif(import_rosbags() is None, reason='rosbags not installed (tools/install_dependencies.sh)')


def _log(time_s, voltage_v, current_a, temperature=None):
    count = len(time_s)
    return RawLog(name='hand', time_s=list(time_s), voltage_v=list(voltage_v), current_a=list(current_a),
                  temperature_c=list(temperature) if temperature is not None else [math.nan] * count,
                  percentage=[math.nan] * count)


# -- hand arithmetic -----------------------------------------------------------------------------------

def test_rc_filter_is_the_recursion_also_across_long_gaps():
    u = np.array([1.0, 1.0, 0.0, 2.0, 2.0, 2.0])
    decay = np.array([0.5, 0.5, 1e-30, 0.9, 0.9, 0.9])
    expected, y = [], 0.3
    for value, d in zip(u, decay):
        y = d * y + (1 - d) * value
        expected.append(y)
    assert np.allclose(rc_filter(u, decay, y0=0.3), expected), 'rc_filter differs from y = d y + (1 - d) u'


def test_pure_resistor_r0_from_current_steps():
    """V = 3.9 V + 0.05 ohm x I, I stepping between 0 and -1 A: R0 is 0.05 ohm (dV / dI)."""
    t = np.arange(0.0, 1200.0)
    i = np.where((t // 60) % 2 == 1, -1.0, 0.0)
    v = 3.9 + 0.05 * i
    result = fit([prepare(_log(t, v, i))], HG2, 'lg_hg2_cell', cells_series=1, holdout=0.0)
    p = result.params
    pack = p.cells_series / p.cells_parallel   # a cell's resistance in the pack
    total = (p.r0_ohm + p.r1_ohm + p.r_fast_ohm) * pack
    assert p.r0_ohm * pack == pytest.approx(0.05, rel=0.05), 'R0 %.4f ohm from steps of 1 A and 50 mV' % (
        p.r0_ohm * pack)
    assert total == pytest.approx(0.05, rel=0.05), 'a pure resistor has no RC pairs: %.4f ohm in all' % total


def test_capacity_from_coulomb_counting_between_two_rests():
    """Rest at SOC 0.9, 1.2 A for 3000 s (1 Ah), rest at SOC 0.5: capacity 1 Ah / 0.4 = 2.5 Ah."""
    ocv = lambda soc: np.interp(soc, HG2.ocv_soc, HG2.ocv_voltage_v)
    t = np.arange(0.0, 4200.0, 5.0)
    i = np.where((t >= 600) & (t < 3600), -1.2, 0.0)
    charge = np.concatenate([[0.0], np.cumsum(i[1:] * 5.0)]) / 3600.0   # Ah, the current of each interval
    soc = 0.9 + charge / 2.5
    v = ocv(soc) + 0.03 * i
    result = fit([prepare(_log(t, v, i))], HG2, 'lg_hg2_cell', cells_series=1, holdout=0.0)
    assert soc[-1] == pytest.approx(0.5, abs=1e-3), 'the hand log ends at SOC 0.5'
    assert result.params.design_capacity_ah == pytest.approx(2.5, rel=0.01), \
        'capacity %.3f Ah, by hand 1 Ah / 0.4 = 2.5 Ah' % result.params.design_capacity_ah


# -- the round trip for each format --------------------------------------------------------------------

@pytest.fixture(scope='module')
def robot_log():
    params = fit_logs.robot_params()
    samples, commands = fit_logs.simulate(params, duration_s=5400.0, seed=7)
    return params, samples, commands


def _write(kind, directory, samples, commands):
    if kind == 'csv':
        path = str(directory / 'log.csv')
        fit_logs.write_csv(path, samples, commands)
    elif kind == 'ros1':
        path = str(directory / 'log.bag')
        fit_logs.write_bag(path, samples, commands, 'ros1')
    else:
        path = str(directory / ('log_' + kind))
        fit_logs.write_bag(path, samples, commands, kind)
    return path


def _check_round_trip(truth, path, output, capsys):
    fit_cli.main([path, '-o', output])
    report = capsys.readouterr().out
    fitted = load_yaml(output)
    assert fitted.cells_series == truth.cells_series, 'cells in series %d, truth %d' % (
        fitted.cells_series, truth.cells_series)
    assert fitted.design_capacity_ah == pytest.approx(truth.design_capacity_ah, rel=0.02), \
        'pack capacity %.3f Ah, truth %.3f Ah' % (fitted.design_capacity_ah, truth.design_capacity_ah)
    pack_r0 = fitted.r0_ohm * fitted.cells_series / fitted.cells_parallel
    true_r0 = truth.r0_ohm * truth.cells_series / truth.cells_parallel
    assert pack_r0 == pytest.approx(true_r0, rel=0.15), 'pack R0 %.4f ohm, truth %.4f ohm' % (pack_r0, true_r0)
    assert fitted.drive_power_w_per_mps == pytest.approx(truth.drive_power_w_per_mps, rel=0.10), \
        'drive power %.1f W/(m/s), truth %.1f' % (fitted.drive_power_w_per_mps, truth.drive_power_w_per_mps)
    held = [line for line in report.splitlines() if line.strip().startswith('held-out part:')]
    assert held, 'the report has no held-out figure:\n' + report
    held_mv = float(held[0].split()[2])
    assert held_mv <= 15.0, 'held-out RMSE %.1f mV per cell (at most 15)' % held_mv
    return report, held_mv


# the ROS 1 bag and MCAP: test_fit_pack.py fits a 4S2P pack from each against the same figures
@pytest.mark.parametrize('kind', ['csv', pytest.param('sqlite3', marks=needs_rosbags)])
def test_round_trip(kind, robot_log, tmp_path, capsys):
    truth, samples, commands = robot_log
    path = _write(kind, tmp_path, samples, commands)
    _check_round_trip(truth, path, str(tmp_path / 'robot.yaml'), capsys)


def test_replay_with_the_config_gives_the_reports_figures(robot_log, tmp_path, capsys):
    """battery_replay of the log's current (the written profile) with the config: the report's RMSE."""
    truth, samples, commands = robot_log
    path = _write('csv', tmp_path, samples, commands)
    output = str(tmp_path / 'robot.yaml')
    fit_cli.main([path, '-o', output, '--profiles', str(tmp_path / 'profiles'), '--plot', str(tmp_path / 'fit.png')])
    report = capsys.readouterr().out
    assert os.path.getsize(tmp_path / 'fit.png') > 10000, '--plot wrote no picture'
    command = [line for line in report.splitlines() if line.startswith('replay: ')][0].split()
    profile, soc = command[2], float(command[-1])
    rows = list(replay(load_yaml(output), read_profile(profile), state_of_charge=soc))
    with open(profile) as stream:
        logged = np.array([float(row['voltage']) for row in csv.DictReader(stream)])
    model = np.array([float(row[1]) for row in rows])
    times = np.array([float(row[0]) for row in rows])
    held = times > 0.75 * times[-1]
    held_mv = 1000.0 * math.sqrt(np.mean((model - logged)[held] ** 2)) / truth.cells_series
    reported = float([line for line in report.splitlines() if 'held-out part:' in line][0].split()[2])
    assert held_mv == pytest.approx(reported, abs=0.1), 'replay %.2f mV per cell, the report %.1f' % (held_mv, reported)


def test_several_logs_fitted_together(tmp_path, capsys):
    truth = fit_logs.robot_params()
    paths = []
    for seed, soc in ((3, 1.0), (4, 0.7)):
        samples, commands = fit_logs.simulate(truth, duration_s=2400.0, seed=seed, soc=soc)
        paths.append(str(tmp_path / ('log%d.csv' % seed)))
        fit_logs.write_csv(paths[-1], samples, commands)
    fit_cli.main(paths + ['-o', str(tmp_path / 'robot.yaml')])
    report = capsys.readouterr().out
    assert report.count('\nlog ') == 2, 'the report should describe both logs:\n' + report
    starts = [float(line.split('starts at SOC ')[1]) for line in report.splitlines() if 'starts at SOC' in line]
    assert starts[0] == pytest.approx(1.0, abs=0.03) and starts[1] == pytest.approx(0.7, abs=0.03), \
        'each log\'s starting SOC: %s (truth 1.0, 0.7)' % starts


def test_a_charge_gives_the_charger(tmp_path, capsys):
    truth = fit_logs.robot_params()
    samples, commands = fit_logs.simulate(truth, duration_s=7200.0, seed=5, charge_at_s=3600.0)
    path = str(tmp_path / 'charge.csv')
    fit_logs.write_csv(path, samples, commands)
    fit_cli.main([path, '-o', str(tmp_path / 'robot.yaml'), '--holdout', '0'])
    fitted = load_yaml(str(tmp_path / 'robot.yaml'))
    assert fitted.charge_current_a == pytest.approx(truth.charge_current_a, rel=0.05), \
        'charge current %.2f A, truth %.2f A' % (fitted.charge_current_a, truth.charge_current_a)


# -- conventions -------------------------------------------------------------------------------------

def test_inverted_current_and_percent_are_found_and_said(robot_log, tmp_path, capsys):
    truth, samples, commands = robot_log
    path = str(tmp_path / 'gazebo.csv')
    fit_logs.write_csv(path, samples, commands, invert_current=True, percent=True)
    report, _ = _check_round_trip(truth, path, str(tmp_path / 'robot.yaml'), capsys)
    assert 'positive = discharging' in report, 'the report must say the current was inverted:\n' + report
    assert '0-100' in report, 'the report must say the percentage was 0-100:\n' + report


def test_duplicated_and_out_of_order_stamps_are_put_right():
    t = [0.0, 1.0, 1.0, 3.0, 2.0] + [float(k) for k in range(4, 120)]
    i = [(-1.0 if (k // 10) % 2 else 0.0) for k in range(len(t))]
    v = [3.9 + 0.05 * c for c in i]
    log = prepare(_log(t, v, i))
    assert np.all(np.diff(log.time_s) > 0), 'the stamps should be sorted and unique'
    assert any('out of order' in note for note in log.notes) and any('duplicated' in note for note in log.notes), \
        'the notes should say what was put right: %s' % log.notes


# -- bad input ---------------------------------------------------------------------------------------

def _refused(argv, capsys, tmp_path, words):
    output = str(tmp_path / 'never.yaml')
    with pytest.raises(SystemExit) as stop:
        fit_cli.main(argv + ['-o', output])
    err = capsys.readouterr().err
    message = str(stop.value.code) if not isinstance(stop.value.code, int) else err
    assert stop.value.code != 0, 'a bad input must end with a non-zero status'
    assert 'Traceback' not in err and len(message.strip().splitlines()) == 1, 'one line, no traceback: %r' % message
    assert all(word in message for word in words), 'the line should say %s: %r' % (words, message)
    assert not os.path.exists(output), 'no config may be written for a bad input'


def _csv(path, rows, header='time,voltage,current'):
    with open(path, 'w') as stream:
        stream.write(header + '\n')
        for row in rows:
            stream.write(','.join(str(x) for x in row) + '\n')
    return str(path)


def test_bad_inputs_are_one_line(tmp_path, capsys):
    steps = [(k, 11.0 + (0.05 if (k // 10) % 2 else 0.0), -1.0 if (k // 10) % 2 else 0.0) for k in range(200)]
    _refused([_csv(tmp_path / 'nan.csv', [(k, 'nan', c) for k, _, c in steps])], capsys, tmp_path, ['NaN'])
    _refused([_csv(tmp_path / 'flat.csv', [(k, 11.0, 0.0) for k in range(200)])], capsys, tmp_path,
             ['constant'])
    _refused([_csv(tmp_path / 'short.csv', steps[:8])], capsys, tmp_path, ['too short'])
    _refused([_csv(tmp_path / 'columns.csv', steps, header='t,v,i')], capsys, tmp_path, ['header'])
    (tmp_path / 'junk.bag').write_bytes(os.urandom(2000))
    _refused([str(tmp_path / 'junk.bag')], capsys, tmp_path, ['junk.bag'])
    (tmp_path / 'junk.csv').write_bytes(b'\xff\xfe\x00' + os.urandom(500))
    _refused([str(tmp_path / 'junk.csv')], capsys, tmp_path, ['junk.csv'])
    _refused([str(tmp_path / 'missing.bag')], capsys, tmp_path, ['no such file'])
    _refused([str(tmp_path / 'flat.csv'), '--cells-series', '0'], capsys, tmp_path, ['--cells-series'])
    _refused([str(tmp_path / 'flat.csv'), '--chemistry', 'unobtainium'], capsys, tmp_path, ['--chemistry'])
    # 11 V as 2 cells: 5.5 V per cell is no cell's (said only that the OCV curve left no room, before)
    _refused([_csv(tmp_path / 'steps.csv', steps), '--cells-series', '2'], capsys, tmp_path,
             ['at 2 cells in series', 'per cell', '--cells-series'])
    # stamps in nanoseconds (a ROS stamp exported as an integer): no pause to cut at, a log of 55,000 hours
    _refused([_csv(tmp_path / 'nanoseconds.csv', [(k * 10 ** 9, v, c) for k, v, c in steps])], capsys, tmp_path,
             ['nanoseconds.csv', 'apart', 'seconds'])


@needs_rosbags
def test_bad_bags_are_one_line(tmp_path, capsys):
    fit_logs.write_bag(str(tmp_path / 'empty.bag'), [], [], 'ros1')
    _refused([str(tmp_path / 'empty.bag')], capsys, tmp_path, ['empty'])
    fit_logs.write_bag(str(tmp_path / 'motion_only'), [], [(0.0, 0.5, 0.1), (0.1, 0.5, 0.1)], 'mcap')
    _refused([str(tmp_path / 'motion_only')], capsys, tmp_path, ['no sensor_msgs/BatteryState'])
    samples, commands = fit_logs.simulate(fit_logs.robot_params(), duration_s=600.0)
    fit_logs.write_bag(str(tmp_path / 'good.bag'), samples, commands, 'ros1')
    _refused([str(tmp_path / 'good.bag'), '--battery-topic', '/nope'], capsys, tmp_path, ['/nope'])


def test_the_script_runs_without_ros(tmp_path):
    """The ROS 1 entry point on a plain interpreter: a bad log is one line and exit status 1."""
    script = os.path.join(os.path.dirname(__file__), '..', '..', 'scripts', 'battery_fit.py')
    env = dict(os.environ, PYTHONPATH=os.path.join(os.path.dirname(__file__), '..', '..', 'src'))
    done = subprocess.run([sys.executable, script, str(tmp_path / 'none.csv'), '-o', str(tmp_path / 'x.yaml')],
                          capture_output=True, text=True, env=env, timeout=60)
    assert done.returncode == 1 and done.stderr.count('\n') == 1 and 'Traceback' not in done.stderr, \
        'exit %d, stderr %r' % (done.returncode, done.stderr)


def test_config_comments_every_fitted_value(robot_log, tmp_path, capsys):
    truth, samples, commands = robot_log
    path = _write('csv', tmp_path, samples, commands)
    output = str(tmp_path / 'robot.yaml')
    fit_cli.main([path, '-o', output])
    capsys.readouterr()
    text = open(output).read()
    values = yaml.safe_load(text)
    assert values['preset'] == 'lg_hg2_cell', 'the config builds on the chemistry preset'
    for line in text.splitlines():
        key = line.split(':')[0]
        if key in ('cell_capacity_ah', 'r0_ohm', 'drive_power_w_per_mps'):
            assert '+-' in line and '#' in line, 'a fitted value needs its source and uncertainty: %r' % line
    assert not any(isinstance(v, float) and not math.isfinite(v) for v in values.values()), 'NaN in the config'


def test_a_users_file_is_never_written_over(tmp_path, capsys):
    """-o naming one of the logs, or a file battery_fit did not write, is refused (one line, exit 2); a config
    it wrote before may be written again."""
    log = _csv(tmp_path / 'run.csv', [(t, 12.0, -1.0) for t in range(30)])
    mine = tmp_path / 'my_robot_config.yaml'
    mine.write_text('preset: lg_hg2_3s1p  # the user\'s own\n')
    for output, words in ((log, 'is one of the logs'), (str(mine), 'is not a config battery_fit wrote')):
        before = open(output).read()
        with pytest.raises(SystemExit) as stop:
            fit_cli.main([log, '-o', output])
        assert stop.value.code == 2
        err = capsys.readouterr().err
        assert words in err and len(err.strip().splitlines()) == 1, err
        assert open(output).read() == before, 'the file must be left as it was'
    from battery_simulator.cli.fit import output_problem
    from battery_simulator.core.fit.config_writer import WRITTEN_BY
    earlier = tmp_path / 'earlier.yaml'
    earlier.write_text(WRITTEN_BY + ': battery_fit run.csv -o earlier.yaml\npreset: lg_hg2_cell\n')
    assert output_problem(str(earlier), [log]) is None
    assert output_problem(str(tmp_path / 'new.yaml'), [log]) is None


def test_plot_and_output_paths_are_checked_before_the_fit(robot_log, tmp_path, capsys):
    """A --plot matplotlib cannot write (a format it does not know, one of the logs, the config itself, a
    directory that does not exist) and an -o in a directory that does not exist are one line and exit 2 before
    the fit: no traceback, no config written, no file touched."""
    truth, samples, commands = robot_log
    log = _write('csv', tmp_path, samples, commands)
    output = str(tmp_path / 'robot.yaml')
    cases = ((['--plot', str(tmp_path / 'fit.txt')], ['--plot', 'fit.txt', 'png']),
             (['--plot', log], ['--plot', 'is one of the logs']),
             (['--plot', output], ['--plot', 'is the config']),
             (['--plot', str(tmp_path / 'no_dir' / 'fit.png')], ['--plot', 'no_dir', 'no such directory']),
             (['--plot', str(tmp_path)], ['--plot', 'is a directory']))
    before = open(log).read()
    for extra, words in cases:
        with pytest.raises(SystemExit) as stop:
            fit_cli.main([log, '-o', output] + extra)
        err = capsys.readouterr().err
        assert stop.value.code == 2, 'exit %r for %s: %r' % (stop.value.code, extra, err)
        assert 'Traceback' not in err and len(err.strip().splitlines()) == 1, 'one line for %s: %r' % (extra, err)
        assert all(word in err for word in words), 'the line should say %s: %r' % (words, err)
        assert not os.path.exists(output), 'no config may be written for %s' % extra
        assert open(log).read() == before, 'the log must be left as it was'
    with pytest.raises(SystemExit) as stop:
        fit_cli.main([log, '-o', str(tmp_path / 'no_dir' / 'robot.yaml')])
    err = capsys.readouterr().err
    assert stop.value.code == 2 and 'no such directory' in err and len(err.strip().splitlines()) == 1, \
        'an -o in a missing directory: exit %r, %r' % (stop.value.code, err)


def test_ctrl_c_while_plotting_leaves_no_config(robot_log, tmp_path, capsys, monkeypatch):
    """'interrupted (no config written)' is true at any moment: the config is written last."""
    truth, samples, commands = robot_log
    log = _write('csv', tmp_path, samples, commands)
    output = str(tmp_path / 'robot.yaml')

    def interrupted(*args):
        raise KeyboardInterrupt

    monkeypatch.setattr(fit_cli, 'plot', interrupted)
    with pytest.raises(SystemExit) as stop:
        fit_cli.main([log, '-o', output, '--plot', str(tmp_path / 'fit.png')])
    err = capsys.readouterr().err
    assert stop.value.code == 130 and 'interrupted (no config written)' in err, (stop.value.code, err)
    assert not os.path.exists(output), 'the report said no config was written, yet one was'


@pytest.mark.parametrize('library, extra', [('numpy', []), ('matplotlib', ['--plot', 'fit.png'])])
def test_ctrl_c_while_the_libraries_load_is_one_line(library, extra, tmp_path):
    """Ctrl-C in the first half second (numpy loading; matplotlib for --plot's check) ends with exit 130 and
    no traceback."""
    code = ('import sys, runpy\n'
            'class CtrlC:\n'
            '    def find_spec(self, name, path=None, target=None):\n'
            '        if name == %r:\n'
            '            raise KeyboardInterrupt\n'
            'sys.meta_path.insert(0, CtrlC())\n'
            'sys.argv = ["battery_fit", "run.csv", "-o", "x.yaml"] + %r\n' % (library, extra) +
            'runpy.run_module("battery_simulator.cli.fit", run_name="__main__")\n')
    env = dict(os.environ, PYTHONPATH=os.path.join(os.path.dirname(__file__), '..', '..', 'src'))
    done = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True, env=env, timeout=60,
                          cwd=str(tmp_path))
    assert done.returncode == 130 and 'Traceback' not in done.stderr and len(done.stderr.strip().splitlines()) == 1, \
        'exit %d, stderr %r' % (done.returncode, done.stderr)


def test_capacity_from_the_percentage_is_not_moved_by_hours_at_a_standstill():
    """tools/benchmark_fit.py's 24 h log at 10 Hz: 3 h of driving to the cut-off, then 21 h standing there, the
    percentage still while the count moves by the current sensor's noise alone. The slopes between pairs of
    samples within the standstill (0: the percentage did not move) took the capacity to 10.8 Ah from the pack's
    9.6 and the held-out part to 87.0 mV per cell; a pair counts where the charge between its samples is at
    least PAIR_MIN_CHARGE of the log's range (then 9.58 Ah, 7.0 mV). Here 7 of 8 of the log stands: before,
    the median slope was 0 and the percentage gave no capacity at all."""
    from battery_simulator.core.fit.conventions import FitLog
    from battery_simulator.core.fit.known import known_charge
    rng = np.random.default_rng(3)
    t = np.arange(0.0, 86400.0, 6.0)
    driving = t < 3 * 3600.0
    current = np.where(driving, -3.0, 0.0) + rng.normal(0.0, 0.02, len(t))
    drawn = np.concatenate([[0.0], np.cumsum(current[:-1] * np.diff(t))]) / 3600.0
    percentage = np.where(driving, 0.95 + drawn / 9.6, 0.95 + drawn[driving][-1] / 9.6)
    voltage = 3.2 + 0.9 * percentage + np.where(driving, -0.03, 0.0)
    log = FitLog(name='standstill', time_s=t, voltage_v=voltage, current_a=current, percentage=percentage)
    capacity = known_charge([log], [np.ones(len(t), dtype=bool)]).capacity_ah
    assert capacity == pytest.approx(9.6, rel=0.02)


# -- messy logs (a hostile probe's findings) ----------------------------------------------------------

def _robot_rows(robot_log):
    """The robot log's samples as CSV rows (time, voltage, current, temperature, percentage)."""
    _, samples, _ = robot_log
    return [(s.time_s, round(s.voltage_v, 4), round(s.current_a, 4), round(s.temperature_c, 2),
             round(s.percentage, 5)) for s in samples]


def test_a_sensors_glitches_are_left_out_with_a_warning(robot_log, tmp_path, capsys):
    """Five samples of 327.67 A (a CAN field's overflow) in the robot's 5 A log gave R0 at its search's bound
    (1e-05 ohm), a 218 A charge limit and 15.8 mV held out, without a word; a current of 1e200 A stopped the
    fit with a traceback (numpy's LinAlgError). Now they are left out and said, and the fit is the clean log's."""
    truth = robot_log[0]
    rows = _robot_rows(robot_log)
    for k in range(len(rows) // 6, len(rows) - 100, len(rows) // 6):
        rows[k] = rows[k][:2] + (327.67,) + rows[k][3:]
    rows[300] = rows[300][:2] + (1e200,) + rows[300][3:]
    header = 'time,voltage,current,temperature,percentage'
    path = _csv(tmp_path / 'glitches.csv', rows, header=header)
    output = str(tmp_path / 'robot.yaml')
    fit_cli.main([path, '-o', output])
    report = capsys.readouterr().out
    assert '5 samples far outside the others left out' in report and '327.67' in report, report
    params = load_yaml(output)
    assert params.r0_ohm == pytest.approx(truth.r0_ohm, rel=0.15), report
    assert params.design_capacity_ah == pytest.approx(truth.design_capacity_ah, rel=0.03), report


def test_a_clock_that_restarted_is_one_line(robot_log, tmp_path, capsys):
    """Stamps that go back to 0 halfway (a reboot) were sorted into the first half, 5400 taken for duplicates
    and dropped, and R0 came out 0.016 ohm (0.026) without a word."""
    rows = _robot_rows(robot_log)
    half = len(rows) // 2
    rows = rows[:half] + [(r[0] - rows[half][0],) + r[1:] for r in rows[half:]]
    _refused([_csv(tmp_path / 'restart.csv', rows, header='time,voltage,current,temperature,percentage')], capsys,
             tmp_path, ['restart.csv', 'goes back', 'restarted'])


def test_a_percentage_that_changes_scale_or_goes_negative_is_not_used(robot_log, tmp_path, capsys):
    """A column 0-1 for half the log and 0-100 after (two logs joined) gave a 970 Ah pack of 6S16P, 322 mV per
    cell held out; negative percentages were read as the gauge's."""
    truth = robot_log[0]
    rows = _robot_rows(robot_log)
    half = len(rows) // 2
    rows = rows[:half] + [r[:4] + (100.0 * r[4],) for r in rows[half:]]
    path = _csv(tmp_path / 'scales.csv', rows, header='time,voltage,current,temperature,percentage')
    output = str(tmp_path / 'robot.yaml')
    fit_cli.main([path, '-o', output])
    report = capsys.readouterr().out
    assert 'the percentage jumps' in report and 'not used' in report, report
    params = load_yaml(output)
    assert (params.cells_series, params.cells_parallel) == (truth.cells_series, truth.cells_parallel), report
    log = prepare(read_log(_csv(tmp_path / 'negative.csv', [r[:4] + (-r[4],) for r in _robot_rows(robot_log)],
                                header='time,voltage,current,temperature,percentage')))
    assert log.percentage is None and any('below 0 left out' in note for note in log.notes), log.notes


def test_a_temperature_in_kelvin_and_a_file_without_lines_are_one_line(tmp_path, capsys):
    steps = [(k, 11.0 + (0.05 if (k // 10) % 2 else 0.0), -1.0 if (k // 10) % 2 else 0.0, 298.15) for k in range(200)]
    _refused([_csv(tmp_path / 'kelvin.csv', steps, header='time,voltage,current,temperature')], capsys, tmp_path,
             ['kelvin', 'Celsius'])
    (tmp_path / 'zeros.csv').write_bytes(b'\0' * 300000)   # /dev/zero grew to 22 GB before the kernel killed it
    _refused([str(tmp_path / 'zeros.csv')], capsys, tmp_path, ['zeros.csv', 'first line is longer'])
    _refused(['/dev/zero'], capsys, tmp_path, ['/dev/zero', 'first line is longer'])


def test_a_plot_written_over_only_where_battery_fit_wrote_it(robot_log, tmp_path, capsys):
    """--plot wrote over a user's picture; a plot battery_fit wrote says so in its metadata and may be written
    again. --chemistry takes LFP and Li-ion in capitals too."""
    truth, samples, commands = robot_log
    log = _write('csv', tmp_path, samples, commands)
    picture = tmp_path / 'holiday.png'
    picture.write_bytes(b'my picture')
    with pytest.raises(SystemExit) as stop:
        fit_cli.main([log, '-o', str(tmp_path / 'robot.yaml'), '--plot', str(picture)])
    err = capsys.readouterr().err
    assert stop.value.code == 2 and 'is not a plot battery_fit wrote' in err, err
    assert picture.read_bytes() == b'my picture'
    plot = tmp_path / 'fit.png'
    for _ in range(2):   # the second run writes over its own plot
        fit_cli.main([log, '-o', str(tmp_path / 'robot.yaml'), '--plot', str(plot)])
        capsys.readouterr()
        assert fit_cli.PLOT_MARK.encode() in plot.read_bytes()
    assert fit_cli.parse_arguments([log, '-o', str(tmp_path / 'x.yaml'), '--chemistry', 'LFP']).chemistry == \
        'a123_lfp_cell'
    assert fit_cli.parse_arguments([log, '-o', str(tmp_path / 'x.yaml'), '--chemistry', 'Li-ion']).chemistry == \
        'lg_hg2_cell'


def test_a_pulse_the_voltage_answers_is_no_glitch():
    """An HPPC test logged every 10 s: a 6C pulse is one sample among hours at rest (0.3 % of them, far above
    the 99th percentile of |current|), and the voltage drops with it by its resistance: kept. The same current
    with the voltage still is a sensor's glitch: left out."""
    t = np.arange(0.0, 36000.0, 10.0)
    pulse = (np.arange(len(t)) % 360) == 180
    i = np.where(pulse, -18.0, 0.0)
    rng = np.random.default_rng(1)
    answered = 3.7 + 0.025 * i + rng.normal(0.0, 0.001, len(t))
    kept = prepare(_log(t, answered, i))
    assert len(kept.time_s) == len(t) and not any('glitch' in note for note in kept.notes), kept.notes
    still = prepare(_log(t, 3.7 + rng.normal(0.0, 0.001, len(t)), np.where(pulse, -18.0, 0.0) + np.where(
        np.arange(len(t)) % 20 < 10, -1.0, 0.0)))
    assert len(still.time_s) == len(t) - pulse.sum() and any('glitch' in note for note in still.notes), still.notes
