"""The package as users consume it: copied into a catkin workspace's src/,
built with catkin_make, installed with catkin_make install, and run with
rosrun/roslaunch from both the devel and the install space."""
import shutil
import subprocess
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[2]
COPY_IGNORE = shutil.ignore_patterns('build', '.git', '__pycache__', '.pytest_cache', '.hypothesis')
ENV = {'PATH': '/usr/bin:/bin', 'HOME': '/tmp', 'LANG': 'C.UTF-8'}


def run_in(workspace, space, command, timeout=600):
    """Run a bash command with ``space``'s setup.bash sourced (or none)."""
    setup = 'source %s/setup.bash && ' % (workspace / space) if space else ''
    result = subprocess.run(['bash', '-c', 'set -e; cd %s && %s%s' % (workspace, setup, command)],
                            env=ENV, capture_output=True, text=True, timeout=timeout)
    assert result.returncode == 0, '%r failed (exit %d):\n%s\n%s' % (
        command, result.returncode, result.stdout[-3000:], result.stderr[-3000:])
    return result.stdout


@pytest.fixture(scope='module')
def workspace(tmp_path_factory):
    root = tmp_path_factory.mktemp('catkin_ws')
    shutil.copytree(PACKAGE, root / 'src' / 'battery_simulator', ignore=COPY_IGNORE)
    run_in(root, None, 'catkin_make -DPYTHON_EXECUTABLE=/usr/bin/python3')
    run_in(root, None, 'catkin_make install -DPYTHON_EXECUTABLE=/usr/bin/python3')
    return root


def test_install_space_holds_scripts_launch_config_and_messages(workspace):
    install = workspace / 'install'
    for script in ('battery_sim_server.py', 'battery_state_pub.py', 'battery_sim_client.py',
                   'battery_replay.py'):
        path = install / 'lib' / 'battery_simulator' / script
        assert path.is_file(), 'missing installed script %s' % path
        shebang = path.read_text().splitlines()[0]   # a node's may block SIGINT while Python starts (env -S)
        assert shebang.startswith('#!') and shebang.endswith('/usr/bin/python3'), \
            '%s not pinned to Debian python: %s' % (path, shebang)
    share = install / 'share' / 'battery_simulator'
    for relative in ('launch/sim.launch', 'config/battery.yaml', 'config/presets/lg_hg2_3s1p.yaml',
                     'action/battery_sim.action', 'package.xml'):
        assert (share / relative).is_file(), 'missing installed file %s' % relative
    messages = list((install / 'lib').glob('python3*/dist-packages/battery_simulator/msg/_battery_simAction.py'))
    assert messages, 'generated Python messages are not in the install space'


@pytest.mark.parametrize('space', ['devel', 'install'])
def test_messages_import_and_rosrun_works(workspace, space):
    out = run_in(workspace, space,
                 "python3 -c 'from battery_simulator.msg import battery_simAction; print(battery_simAction._type)'")
    assert out.strip() == 'battery_simulator/battery_simAction'
    out = run_in(workspace, space, 'rosrun battery_simulator battery_replay.py --list-presets')
    assert 'lg_hg2_3s1p' in out, out


@pytest.mark.parametrize('space', ['devel', 'install'])
def test_roslaunch_resolves_sim_launch(workspace, space):
    out = run_in(workspace, space, 'roslaunch --nodes battery_simulator sim.launch')
    assert '/BatterySimServer' in out and '/battery_state_pub' in out, out
