#!/usr/bin/python3
"""rostest: SIGINT or SIGTERM at any moment of a node's life (importing, starting, running) ends it
within 2 s, without a traceback. Each node is started as a shell starts a background job: with
SIGINT ignored, the way a signal used to be lost while the node imported rospy."""
import concurrent.futures
import itertools
import signal
import subprocess
import time
import unittest

import rostest

from rostest_helpers import node_command, stop_process

END_WITHIN_S = 2.0
RUN_NUMBERS = itertools.count()
#: script -> its private parameters (each node its own name; a dashboard its own port)
NODES = {
    'battery_fleet.py': ['_robots:=20'],
    'battery_sim_server.py': [],
    'battery_state_pub.py': [],
    'battery_dashboard.py': ['_port:=%d'],
    'sim_clock.py': ['_wait_for:=[/never_published]'],
    'patrol_and_dock.py': [],
    'fake_base.py': [],
    'battery_dock_contact.py': [],
    'battery_cmd_vel_gate.py': [],
}
#: (delay after start, s; signal): while importing rospy, while starting, once up
MOMENTS = ((0.2, signal.SIGINT), (1.0, signal.SIGTERM), (3.0, signal.SIGINT))


def _as_background_job():
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def stop_at(script, delay_s, signum):
    """Start ``script``, send ``signum`` after ``delay_s``: (seconds it took to end or None, output)."""
    number = next(RUN_NUMBERS)
    params = [p % (18600 + number) if '%d' in p else p for p in NODES[script]]
    command = node_command(script) + ['__name:=signalled_%d' % number] + params
    process = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                               start_new_session=True, preexec_fn=_as_background_job)
    try:
        time.sleep(delay_s)   # the moment under test: not a wait for a condition
        process.send_signal(signum)
        sent = time.monotonic()
        try:
            process.wait(timeout=END_WITHIN_S + 3.0)
            took = time.monotonic() - sent
        except subprocess.TimeoutExpired:
            took = None
    finally:
        stop_process(process, signal.SIGKILL, 5.0)
    return took, process.stdout.read()


class TestSignals(unittest.TestCase):

    def test_every_node_ends_within_2_s_of_a_signal_at_any_moment(self):
        cases = [(script, delay, signum) for script in NODES for delay, signum in MOMENTS]
        with concurrent.futures.ThreadPoolExecutor(max_workers=3) as pool:
            results = dict(zip(cases, pool.map(lambda case: stop_at(*case), cases)))
        problems = []
        for (script, delay, signum), (took, output) in results.items():
            if took is None:
                problems.append('%s ignored signal %d sent %g s after its start:\n%s' % (script, signum, delay, output))
            elif took > END_WITHIN_S:
                problems.append('%s took %.2f s to end (signal %d at %g s)' % (script, took, signum, delay))
            elif 'Traceback' in output:
                problems.append('%s printed a traceback (signal %d at %g s):\n%s' % (script, signum, delay, output))
        self.assertEqual(problems, [], '\n'.join(problems))


if __name__ == '__main__':
    rostest.rosrun('battery_simulator', 'test_signals', TestSignals)
