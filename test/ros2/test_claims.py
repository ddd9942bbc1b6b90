"""Issue 40 item 11: a duplicate battery_sim is refused before it says "ready". On a busy machine discovery can
take longer than the claim's 1.5 s of listening: the duplicate ran (logged "ready", 8-280 ms) before the earlier
claim arrived. Now it listens on while the graph shows a claim publisher whose claim has not come."""
import json
import os
import re
import time

import pytest
from std_msgs.msg import String

from battery_simulator.ros2 import battery_claims, local_claims, startup
from ros2_probe import NodeProcess


class SlowDiscovery:
    """A node and an executor for BatteryClaim: the graph shows ``publishers`` claim publishers (ours included)
    at once, and the earlier claim of another process arrives ``delay_s`` after the start (a busy machine)."""

    def __init__(self, publishers, delay_s, claim):
        self.publishers, self.delay_s, self.claim = publishers, delay_s, claim
        self.started = time.monotonic()
        self.callback = None
        self.delivered = False

    # the node
    def create_subscription(self, msg_type, topic, callback, qos):
        self.callback = callback

    def create_publisher(self, msg_type, topic, qos):
        return self

    def publish(self, msg):
        self.callback(msg)   # our own claim comes back to us, as DDS delivers it

    def count_publishers(self, topic):
        return self.publishers

    def get_logger(self):
        return self

    def fatal(self, text):
        pass

    # the executor
    def spin_once(self, timeout_sec):
        time.sleep(timeout_sec)
        if not self.delivered and time.monotonic() >= self.started + self.delay_s:
            self.delivered = True
            self.callback(String(data=json.dumps(self.claim)))


def test_a_claim_that_arrives_after_the_first_listening_still_refuses_the_later_start():
    earlier = {'order': [1, 'host', 123], 'names': ['/dup'], 'node': '/dup/battery_simulator'}
    world = SlowDiscovery(publishers=2, delay_s=battery_claims.CLAIM_WAIT_S + 1.0, claim=earlier)
    claim = battery_claims.BatteryClaim(world, ['/dup'], '/dup/battery_simulator')
    with pytest.raises(startup.StartupError, match='already served by /dup/battery_simulator'):
        claim.wait(world)


def test_a_claim_publisher_that_never_delivers_delays_the_start_by_a_bounded_time():
    world = SlowDiscovery(publishers=2, delay_s=1e9, claim=None)   # a publisher that was SIGKILLed: never delivers
    claim = battery_claims.BatteryClaim(world, ['/alone'], '/alone/battery_simulator')
    started = time.monotonic()
    claim.wait(world, wait_s=0.2, most_s=1.0)
    assert 0.9 <= time.monotonic() - started < 3.0


def test_alone_the_claim_listens_only_its_first_time():
    world = SlowDiscovery(publishers=1, delay_s=1e9, claim=None)
    claim = battery_claims.BatteryClaim(world, ['/alone'], '/alone/battery_simulator')
    started = time.monotonic()
    claim.wait(world, wait_s=0.3, most_s=5.0)
    assert time.monotonic() - started < 2.0


@pytest.mark.parametrize('attempt', range(2))
def test_of_two_battery_sims_started_together_the_loser_never_says_ready(attempt):
    ns = '/readydup%d' % attempt
    both = [NodeProcess('battery_sim', '-r', '__ns:=' + ns) for _ in range(2)]
    try:
        deadline = time.monotonic() + 20.0
        while time.monotonic() < deadline and all(p.process.poll() is None for p in both):
            time.sleep(0.05)
        ended = [p for p in both if p.process.poll() is not None]
        assert len(ended) == 1, '\n---\n'.join(p.output() for p in both)
        assert ended[0].process.returncode == 2 and 'already served by' in ended[0].output(), ended[0].output()
        assert not re.search(r'\bready\b', ended[0].output()), 'the duplicate said it was ready:\n' + ended[0].output()
    finally:
        for process in both:
            process.stop()


def test_a_battery_killed_and_not_yet_reaped_does_not_block_its_restart():
    """SIGKILL leaves a zombie until its parent waits: its registry entry must not refuse the restart."""
    import signal
    import subprocess
    first = subprocess.Popen(['battery_sim', '--ros-args', '-r', '__ns:=/zombie'], stdout=subprocess.DEVNULL,
                             stderr=subprocess.STDOUT)
    again = None
    try:
        deadline = time.monotonic() + 30.0
        path = local_claims.registry_path()
        while time.monotonic() < deadline and not (os.path.exists(path) and '/zombie' in open(path).read()):
            time.sleep(0.1)
        first.send_signal(signal.SIGKILL)
        time.sleep(0.5)   # dead, not reaped: a zombie
        again = NodeProcess('battery_sim', '-r', '__ns:=/zombie')
        assert again.wait_for_output('battery_simulator ready', 30.0), again.output()
    finally:
        first.kill()
        first.wait()
        if again is not None:
            again.stop()
