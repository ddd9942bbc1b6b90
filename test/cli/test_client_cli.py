"""battery_sim_client.py's command line, read before any ROS import."""
import os
import subprocess
import sys
from pathlib import Path

import pytest

from battery_simulator.cli.client_cli import CHOICES, parse_arguments

SRC = Path(__file__).resolve().parents[2] / 'src'


@pytest.mark.parametrize('goal, charge', [('1', True), ('charge', True), ('0', False), ('discharge', False)])
def test_each_goal_spelling(goal, charge):
    args = parse_arguments([goal])
    assert CHOICES[args.goal] is charge
    assert (args.timeout, args.server_timeout) == (0.0, 10.0)


def test_timeouts_are_seconds():
    args = parse_arguments(['1', '--timeout', '2.5', '--server-timeout', '0.5'])
    assert (args.timeout, args.server_timeout) == (2.5, 0.5)
    assert parse_arguments(['1', '--timeout', '0']).timeout == 0.0   # 0 waits for ever


@pytest.mark.parametrize('option, text, message', [
    ('--timeout', '-1', '-1 is not a number of seconds >= 0'),
    ('--timeout', 'nan', 'nan is not a number of seconds >= 0'),
    ('--timeout', 'soon', 'soon is not a number of seconds >= 0'),
    ('--server-timeout', '0', '0 is not a number of seconds > 0'),
    ('--server-timeout', 'inf', 'inf is not a number of seconds > 0'),
])
def test_bad_seconds_name_the_value(option, text, message, capsys):
    with pytest.raises(SystemExit) as exited:
        parse_arguments(['1', option, text])
    assert exited.value.code == 2
    assert message in capsys.readouterr().err


def run_cli(*argv):
    """main(argv) in a fresh interpreter: the exit code, stderr, and whether rospy got imported."""
    code = ('import sys\nfrom battery_simulator.cli.client_cli import main\n'
            'try:\n    main(%r)\nexcept SystemExit as exit:\n'
            '    print(exit.code, "rospy" in sys.modules)\n' % (list(argv),))
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(SRC), os.environ.get('PYTHONPATH', '')]))
    result = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True, env=env, timeout=60)
    exit_code, rospy_imported = result.stdout.split()[-2:]
    return exit_code, result.stderr, rospy_imported == 'True'


@pytest.mark.parametrize('argv', [['2'], [], ['1', '--timeout', 'x']])
def test_a_usage_error_exits_2_before_any_ros_import(argv):
    exit_code, err, rospy_imported = run_cli(*argv)
    assert exit_code == '2' and 'usage: battery_sim_client.py' in err
    assert not rospy_imported


def test_remap_arguments_are_not_goals():
    exit_code, err, _ = run_cli('__name:=client', '2')
    assert exit_code == '2' and "invalid choice: '2'" in err and '__name' not in err


def test_a_ctrl_c_whose_exit_a_finaliser_swallowed_still_exits_130_before_any_goal():
    # the signal lands while a finaliser runs: Python prints "Exception ignored in" and carries on starting; the
    # client must still end with 130 (a clean-clone CI run with two CPU hogs charged to full and exited 0)
    code = ('import os, signal, sys\nfrom battery_simulator.cli import client_cli\n'
            'class Finaliser:\n    def __del__(self):\n        os.kill(os.getpid(), signal.SIGINT)\n'
            'reading = client_cli.goal_request\n'
            'def goal_request(argv):\n    request = reading(argv)\n    Finaliser()\n    return request\n'
            'client_cli.goal_request = goal_request\n'
            'try:\n    client_cli.main(["1", "--server-timeout", "1"])\nexcept SystemExit as exit:\n'
            '    print(exit.code)\n')
    # the built package's messages first (devel's PYTHONPATH), then the sources
    paths = [p for p in os.environ.get('PYTHONPATH', '').split(os.pathsep) if p and Path(p).resolve() != SRC]
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(paths + [str(SRC)]),
               ROS_MASTER_URI='http://127.0.0.1:9')   # nothing listens on the discard port: no goal can go
    result = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True, env=env, timeout=60)
    assert result.stdout.split()[-1:] == ['130'], result.stdout + result.stderr   # before: 3, no ROS master
    assert 'cancelled' in result.stdout
    assert 'Traceback' not in result.stderr and 'Exception ignored' not in result.stderr, result.stderr
