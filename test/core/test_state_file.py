"""One state file, one battery (issue 40 item 7): a second battery given a state file that a running one
holds is refused naming the file's holder; a holder killed with SIGKILL leaves nothing that blocks a restart."""
import json
import os
import signal
import subprocess
import sys
import textwrap

import pytest

from battery_simulator.core.state_file import (StateFileError, check_state_file, hold_state_file,
                                               release_state_file)

HOLDER = textwrap.dedent('''
    import sys, time
    from battery_simulator.core.state_file import check_state_file
    check_state_file(sys.argv[1], holder='/s1/BatterySimServer')
    print('held', flush=True)
    time.sleep(60)
''')


@pytest.fixture
def holder_process():
    """Start a process that holds a state file; yields a function (path) -> the process, holding it."""
    started = []

    def start(path):
        env = dict(os.environ, PYTHONPATH=os.pathsep.join(p for p in sys.path if p))
        process = subprocess.Popen([sys.executable, '-c', HOLDER, path], stdout=subprocess.PIPE, env=env, text=True)
        started.append(process)
        assert process.stdout.readline().strip() == 'held', 'the holder did not start'
        return process
    yield start
    for process in started:
        if process.poll() is None:
            process.kill()
        process.wait()


def test_a_second_battery_is_refused_naming_the_one_that_holds_it(tmp_path, holder_process):
    path = str(tmp_path / 'shared.json')
    first = holder_process(path)
    with pytest.raises(StateFileError) as refused:
        check_state_file(path, holder='/s2/BatterySimServer')
    assert '/s1/BatterySimServer' in str(refused.value) and 'process %d' % first.pid in str(refused.value)
    assert '\n' not in str(refused.value)


def test_a_state_file_held_by_a_killed_battery_can_be_taken(tmp_path, holder_process):
    path = str(tmp_path / 'state.json')
    first = holder_process(path)
    first.send_signal(signal.SIGKILL)
    first.wait()
    try:
        check_state_file(path, holder='/s1/BatterySimServer')   # the respawned one
    finally:
        release_state_file(path)


def test_a_fleets_state_file_is_held_too(tmp_path):
    path = str(tmp_path / 'fleet.json')
    (tmp_path / 'fleet.json').write_text(json.dumps({'robots': {}}))
    check_state_file(path, fleet=True, holder='/battery_fleet')
    try:
        with pytest.raises(StateFileError, match='/battery_fleet'):
            check_state_file(path, fleet=True, holder='/battery_fleet_1')
        check_state_file(path, fleet=True, holder='/battery_fleet')   # its own holder asks again: fine
    finally:
        release_state_file(path)


def test_without_a_holder_nothing_is_held(tmp_path):
    path = str(tmp_path / 'state.json')
    check_state_file(path)
    hold_state_file(path, '/a')
    release_state_file(path)
    hold_state_file(path, '/b')
    release_state_file(path)
