"""Issue 40 item 3: a fleet host of 100 robots ends within 2 s of SIGINT or SIGTERM, its state saved first (the
interpreter's teardown of every rcl object took 5.5 s here, 14.7-15.5 s in the issue). The contract's bound is
2 s; the test allows 3 s for a loaded machine and prints the figure."""
import os
import signal
import time

import pytest

from ros2_probe import NodeProcess

ROBOTS = 100
CONTRACT_S = 2.0
LOADED_MACHINE_S = 3.0


@pytest.mark.parametrize('sig', [signal.SIGINT])   # SIGTERM takes the same path (test_hardening: at 1 robot)
def test_a_fleet_of_100_ends_within_2_s_of_a_stop_signal_its_state_saved(tmp_path, sig):
    state_file = str(tmp_path / 'fleet.json')
    process = NodeProcess('battery_fleet', '-r', '__ns:=/', '-p', 'robots:=%d' % ROBOTS,
                          '-p', 'prefix:=stop%d_' % sig, '-p', 'state_file:=' + state_file)
    try:
        assert process.wait_for_output('battery_fleet ready', 120.0), process.output()
        deadline = time.monotonic() + 10.0
        while not os.path.exists(state_file) and time.monotonic() < deadline:
            time.sleep(0.1)
        if os.path.exists(state_file):
            os.remove(state_file)   # what exists after the signal was written at the stop
        started = time.monotonic()
        os.kill(process.pid, sig)
        code = process.wait(30.0)
        took = time.monotonic() - started
        print('battery_fleet robots:=%d ended %.2f s after %s' % (ROBOTS, took, signal.Signals(sig).name))
        assert code == 0, 'exit %s:\n%s' % (code, process.output()[-2000:])
        assert took <= LOADED_MACHINE_S, '%.2f s to end after %s (contract: %g s)' % (
            took, signal.Signals(sig).name, CONTRACT_S)
        assert os.path.exists(state_file), 'the state was not saved at the stop'
        assert 'Traceback' not in process.output(), process.output()[-2000:]
    finally:
        process.stop(signal.SIGKILL)
