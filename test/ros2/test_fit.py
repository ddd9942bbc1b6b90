"""battery_fit on ROS 2 (under tools/ros2.sh): the installed executable fits an MCAP bag and a sqlite3 bag
made with this simulator (rosbags from the venv), and the config it writes loads in battery_sim."""
import os
import shutil
import subprocess
import sys

import pytest

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, '..', 'core'))

import fit_logs  # noqa: E402
from battery_simulator.core.config_files import load_yaml  # noqa: E402


@pytest.fixture(scope='module')
def robot_log():
    params = fit_logs.robot_params()
    samples, commands = fit_logs.simulate(params, duration_s=3600.0, seed=9)
    return params, samples, commands


@pytest.mark.parametrize('storage', ['mcap', 'sqlite3'])
def test_battery_fit_executable_on_a_ros2_bag(storage, robot_log, tmp_path):
    truth, samples, commands = robot_log
    bag = str(tmp_path / ('log_' + storage))
    fit_logs.write_bag(bag, samples, commands, storage)
    executable = shutil.which('battery_fit')
    assert executable, 'battery_fit is not installed on the PATH of tools/ros2.sh'
    output = str(tmp_path / 'robot.yaml')
    done = subprocess.run([executable, bag, '-o', output], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, 'battery_fit failed: %s' % done.stderr
    fitted = load_yaml(output)
    assert fitted.cells_series == truth.cells_series, 'cells in series %d, truth %d' % (fitted.cells_series,
                                                                                        truth.cells_series)
    assert fitted.design_capacity_ah == pytest.approx(truth.design_capacity_ah, rel=0.02), \
        'pack capacity %.3f Ah, truth %.3f' % (fitted.design_capacity_ah, truth.design_capacity_ah)
    assert 'held-out part:' in done.stdout, 'no report on stdout: %r' % done.stdout[:500]


def test_battery_fit_bad_bag_is_one_line(tmp_path):
    (tmp_path / 'junk.mcap').write_bytes(b'\x89MCAP0\r\n' + os.urandom(300))
    done = subprocess.run([shutil.which('battery_fit'), str(tmp_path / 'junk.mcap'), '-o', str(tmp_path / 'x.yaml')],
                          capture_output=True, text=True, timeout=60)
    assert done.returncode == 1 and done.stderr.count('\n') == 1 and 'Traceback' not in done.stderr, \
        'exit %d, stderr %r' % (done.returncode, done.stderr)
    assert not (tmp_path / 'x.yaml').exists(), 'no config for a bad bag'
