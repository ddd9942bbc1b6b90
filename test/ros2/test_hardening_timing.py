"""The ROS 2 front end's hardening that measures time (issue 33, Part 4 items 11, 13, 14, 17, 18 and a low
item; issue 40 item 6): a stop signal during a goal, predict beside the batteries, two /clock publishers, the
client beside a dead server, a fleet killed at x300. Split from test_hardening.py (whose checks do not
measure time) so that the two run side by side: this one holds ctest's "timing" lock (never beside another
test that measures latencies), the other runs beside anything. Latencies are compared with a reference
measured in the same run.

Each process runs in a namespace of its own; every wait has a bound."""
import contextlib
import json
import math
import os
import random
import select
import signal
import statistics
import subprocess
import sys
import threading
import time

import pytest
from action_msgs.msg import GoalStatus, GoalStatusArray
from rclpy.time import Time
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import BatteryState
from std_msgs.msg import Bool

from battery_simulator.action import BatterySim
from battery_simulator.core.prediction import MAX_SEGMENTS
from battery_simulator.core.state_file import fleet_save_period_s
from battery_simulator.srv import Predict
from ros2_probe import LATCHED, NodeProcess, Probe
from test_hardening import CHARGING, started, stop_all, wait_until


@pytest.fixture(scope='module')
def probe():
    probe = Probe('hardening_timing_probe')
    yield probe
    probe.close()


# -- items 11 and 18: a goal runs EXECUTING, and a stop signal ends it ----------------------------------

def goal_status(probe, ns, status, timeout_s=5.0):
    """The first goal status array (the action's latched status topic) that has a goal in ``status``."""
    return probe.wait_for(ns + '/battery_simulator/_action/status', GoalStatusArray,
                          lambda msg: any(s.status == status for s in msg.status_list), timeout_s, qos=LATCHED)


@pytest.mark.parametrize('executable,sig', [('battery_sim', signal.SIGINT), ('battery_sim', signal.SIGTERM),
                                            ('battery_state_pub', signal.SIGINT), ('battery_fleet', signal.SIGTERM)])
def test_stop_with_an_active_goal_aborts_it_saves_and_exits_0(probe, tmp_path, executable, sig):
    state_file = str(tmp_path / 'state.json')
    ns = '/stop_%s_%d' % (executable, sig)
    if executable == 'battery_fleet':
        process = NodeProcess(executable, '-p', 'robots:=1', '-p', 'prefix:=' + ns.strip('/') + '_',
                              '-p', 'state_file:=' + state_file, '-p', 'initial_percentage:=50.0')
        ns = ns + '_0'
    else:
        process = NodeProcess(executable, '-r', '__ns:=' + ns, '-p', 'state_file:=' + state_file,
                              '-p', 'initial_percentage:=50.0', '-p', 'wait_s:=0.5')
    try:
        started(probe, ns, process)
        client = probe.action_client(BatterySim, ns + '/battery_simulator')
        probe.follow(ns + '/battery_simulator/_action/status', GoalStatusArray, LATCHED)
        handle = probe.send_goal(client, BatterySim.Goal(charge_state=True))
        assert goal_status(probe, ns, GoalStatus.STATUS_EXECUTING) is not None, \
            'the goal is not EXECUTING while it runs (item 18)'
        if os.path.exists(state_file):
            os.remove(state_file)
        asked = handle.get_result_async()   # as a client does: it asks for the result once the goal is accepted
        time.sleep(0.3)
        os.kill(process.pid, sig)
        result = probe._result(asked, 5.0, 'the goal\'s result after %s' % sig)
        assert result.status == GoalStatus.STATUS_ABORTED and 'shutting down' in result.result.battery_status, \
            (result.status, result.result.battery_status)
        assert process.wait(5.0) == 0, 'exit %s:\n%s' % (process.process.returncode, process.output())
        assert 'Traceback' not in process.output() and 'RCLError' not in process.output(), process.output()
        assert os.path.exists(state_file), 'the state was not saved at shutdown'
    finally:
        stop_all(process)


# -- item 13: predict never delays the batteries -----------------------------------------------------

def test_a_predict_flood_does_not_delay_another_robot(probe):
    """4 clients flood robot0 of a fleet host with plans of the contract's most segments (100,000 power loads
    that differ, 6 s each: a week; 1.6 s of CPU each): robot1 follows its contact within max(0.5 s, 5 x its own
    median before the flood, measured in this run) and robot2's
    battery_status keeps its 1 s period (within 0.2 s). Predict in the host's executor (the old design)
    made them 0.8 s and 1.6 s here (3.6 s and 1.8 s in the issue)."""
    fleet = NodeProcess('battery_fleet', '-p', 'robots:=3', '-p', 'prefix:=flood', '-p', 'time_scale:=1.0')
    stop = threading.Event()
    answered = []
    try:
        for robot in range(3):
            started(probe, '/flood%d' % robot, fleet)
        reference = contact_delays(probe, '/flood1', timeout_s=10.0)   # robot1 before the flood, this run
        count = MAX_SEGMENTS
        plan = Predict.Request(duration_s=[6.0] * count, power_w=[1.0 + 0.5 * (i % 7) for i in range(count)])

        def flood():
            while not stop.is_set():
                try:
                    answered.append(probe.call(Predict, '/flood0/battery_simulator/predict', plan,
                                               timeout_s=30.0).success)
                except AssertionError:
                    pass
        threads = [threading.Thread(target=flood, daemon=True) for _ in range(4)]
        for thread in threads:
            thread.start()
        assert wait_until(lambda: answered, 30.0), 'no predict answered within 30 s'
        status2 = probe.follow('/flood2/battery_status', BatteryState)
        measured_from, answered_before = time.monotonic(), len(answered)
        delays = contact_delays(probe, '/flood1', timeout_s=10.0)
        stop.wait(max(0.0, measured_from + 6.0 - time.monotonic()))   # robot2's period over 6 s at least
        arrivals = [at for at, _ in list(status2) if at >= measured_from]
        period_s = (arrivals[-1] - arrivals[0]) / (len(arrivals) - 1) if len(arrivals) > 1 else math.inf
        during = answered[answered_before:]
        bound = max(0.5, 5.0 * statistics.median(reference))
        assert statistics.median(delays) < bound, 'contact -> status delays during a flood of robot0: %s (before it: %s)' % (
            ', '.join('%.2f s' % delay for delay in delays), ', '.join('%.2f s' % delay for delay in reference))
        assert 0.8 <= period_s <= 1.2, "robot2's battery_status period during the flood: %.2f s (%d messages)" % (
            period_s, len(arrivals))
        # answered while measured: the plan's answers, or busy (on a loaded machine a plan of the most segments
        # takes its worker longer than a caller waits, 7 s: the worker goes on computing, the caller hears busy)
        assert len(during) > 0, 'the flood went on while measured (%d answers, %d successful)' % (
            len(during), sum(during))
    finally:
        stop.set()
        stop_all(fleet)


# -- item 14: two /clock publishers ------------------------------------------------------------------

def test_two_clocks_600_s_apart_drain_no_faster_than_one(probe):
    """Two /clock publishers at the same speed (20x), 600 s apart, their ticks interleaved: the battery
    drains as one clock alone makes it (on main: every jump forwards counted, 27 points in 5 s)."""
    speed, tick_s = 20.0, 0.005
    start_s = 1.7e9
    clocks = [probe.node.create_publisher(Clock, '/clock', 10) for _ in range(2)]
    now = [start_s]
    second_clock = threading.Event()
    stop = threading.Event()

    def tick():
        chooser = random.Random(14)
        while not stop.wait(tick_s):
            now[0] += speed * tick_s
            order = [0, 1] if chooser.random() < 0.5 else [1, 0]
            for index in order:
                if index == 0 or second_clock.is_set():
                    clocks[index].publish(Clock(clock=Time(seconds=now[0] + 600.0 * index).to_msg()))
    ticker = threading.Thread(target=tick, daemon=True)
    ticker.start()
    process = NodeProcess('battery_sim', '-r', '__ns:=/twoclocks', '-p', 'use_sim_time:=true',
                          '-p', 'initial_percentage:=80.0')
    try:
        first = probe.wait_for('/twoclocks/battery_status', BatteryState,
                               lambda m: m.header.stamp.sec > start_s + 5.0, 25.0)
        assert first is not None, 'no battery_status on the first clock:\n' + process.output()
        since = time.monotonic()
        second_clock.set()
        assert probe.wait_for('/twoclocks/battery_status', BatteryState,
                              lambda m: m.header.stamp.sec > now[0] + 500.0, 10.0, since=since) is not None, \
            'no battery_status stamped on the second clock'
        stop.wait(5.0)
        last = probe.wait_for('/twoclocks/battery_status', BatteryState, timeout_s=5.0, since=time.monotonic())
        assert last is not None, process.output()
        elapsed_s = (time.monotonic() - since + 2.0) * speed   # + an update either side
        one_clock = 1.5 * elapsed_s / 3600.0 / first.capacity
        drained = first.percentage - last.percentage
        assert -1e-4 <= drained <= 1.5 * one_clock + 0.002, \
            'two clocks 600 s apart drained %.2f points in %.1f s (one clock: %.2f points)' % (
                100 * drained, elapsed_s / speed, 100 * one_clock)
    finally:
        stop.set()
        ticker.join(2.0)
        for clock in clocks:
            probe.node.destroy_publisher(clock)
        assert process.stop() == 0, process.output()


# -- item 17: the client notices a dead server -------------------------------------------------------

def test_client_notices_its_server_died(probe):
    server = NodeProcess('battery_sim', '-r', '__ns:=/dead', '-p', 'time_scale:=1.0', '-p', 'initial_percentage:=50.0')
    client = None
    try:
        started(probe, '/dead', server)
        client = NodeProcess('battery_sim_client', '-r', '__ns:=/dead', args=['1'])
        assert client.wait_for_output('harging', 15.0), client.output()
        time.sleep(1.0)
        server.stop(signal.SIGKILL)
        code = client.wait(8.0)
        assert code == 1, 'the client did not exit 1 within 8 s of its server\'s death (%s):\n%s' % (
            code, client.output())
    finally:
        stop_all(server, *([client] if client else []))


def test_client_ctrl_c_ends_it_within_2_s(probe):
    server = NodeProcess('battery_sim', '-r', '__ns:=/ctrlc', '-p', 'time_scale:=1.0', '-p', 'initial_percentage:=50.0')
    client = None
    try:
        started(probe, '/ctrlc', server)
        client = NodeProcess('battery_sim_client', '-r', '__ns:=/ctrlc', args=['1'])
        assert client.wait_for_output('harging', 15.0), client.output()
        server.stop(signal.SIGKILL)
        start = time.monotonic()
        os.kill(client.pid, signal.SIGINT)
        assert client.wait(2.0) is not None, 'Ctrl-C took more than 2 s:\n' + client.output()
        assert time.monotonic() - start < 2.0
    finally:
        stop_all(server, *([client] if client else []))


# -- low: a fleet's state file after SIGKILL ---------------------------------------------------------

def test_a_fleet_killed_at_x300_resumes_within_1_percent(probe, tmp_path):
    """A fleet host at time x300 (updates at 1 Hz: 300 s of battery each) killed with SIGKILL just before
    an update resumes within 1 point of the level it had when killed (on main: the last update's, up to
    4.5 points higher)."""
    args = ('-p', 'robots:=1', '-p', 'prefix:=killed', '-p', 'time_scale:=300.0',
            '-p', 'state_file:=' + str(tmp_path / 'fleet.json'))
    fleet = NodeProcess('battery_fleet', *args)
    try:
        started(probe, '/killed0', fleet)
        statuses = probe.follow('/killed0/battery_status', BatteryState)
        assert wait_until(lambda: len({round(m.percentage, 6) for _, m in list(statuses)}) >= 3, 10.0), \
            'battery_status did not move:\n' + fleet.output()
        (_, previous), (_, last) = list(statuses)[-2:]
        stamp = lambda msg: msg.header.stamp.sec + 1e-9 * msg.header.stamp.nanosec
        rate = (previous.percentage - last.percentage) / (stamp(last) - stamp(previous))   # per wall second
        # the reference, measured in this run: how late this machine delivers an update (between stamp and
        # receipt, against the first message's); on a busy machine the level at the kill is known only that well
        seen = list(statuses)
        lateness_s = max(at - stamp(msg) for at, msg in seen) - min(at - stamp(msg) for at, msg in seen)
        assert rate > 0.0, 'not draining'
        killed_at = stamp(last) + 0.9   # just before the next update
        # the host's writes of its state file until the kill (its saves, every 0.067 s at x300): the other reference
        # measured in this run, how late this machine lets the host save (a fresh-clone run with two CPU hogs
        # resumed 1.39 points above the level at the kill: the last save was 0.3 s old)
        state_file, writes = tmp_path / 'fleet.json', set()
        while time.time() < killed_at:
            with contextlib.suppress(FileNotFoundError):
                writes.add(state_file.stat().st_mtime_ns / 1e9)
            time.sleep(0.005)
        killed_at = time.time()
        fleet.process.kill()
        killed_by = time.time()   # the kill fell between the two (a busy machine put 0.25 s there: 1.1 points)
        level = 100.0 * (last.percentage - rate * (killed_at - stamp(last)))
        level_after = 100.0 * (last.percentage - rate * (killed_by - stamp(last)))
        with contextlib.suppress(FileNotFoundError):
            writes.add(state_file.stat().st_mtime_ns / 1e9)
    finally:
        fleet.stop(signal.SIGKILL)
    # saved between updates (on main it was only at each update, once in that 0.9 s), and how old the last save was
    assert len(writes) >= 3, 'the state file was written %d times in the 0.9 s before the kill' % len(writes)
    save_late_s = max(0.0, killed_at - max(writes) - fleet_save_period_s(300.0))
    again = NodeProcess('battery_fleet', *args)
    try:
        assert again.wait_for_output('resumed from', 20.0), again.output()
        line = next(line for line in again.output().splitlines() if 'resumed from' in line)
        resumed = float(line.split('resumed from')[1].split(':')[1].split('%')[0])
        allowed = 1.0 + 100.0 * rate * max(lateness_s, save_late_s)
        assert level_after - allowed <= resumed <= level + allowed, 'killed at %.2f-%.2f %%, resumed at %.1f %% ' \
            '(allowed %.2f: deliveries up to %.3f s late here, the last save %.3f s later than its period):\n%s' % (
                level_after, level, resumed, allowed, lateness_s, save_late_s, line)
    finally:
        assert again.stop() == 0, again.output()


# -- issue 40 item 6: predicts at once, and a flood beside a lone battery ------------------------------

PREDICTS_AT_ONCE = 40
ANSWER_WITHIN_S = 10.0


def biggest_plan():
    """The most segments a plan may have, each of its own load (a week; 1.6 s of a worker's CPU here)."""
    return Predict.Request(duration_s=[6.0] * MAX_SEGMENTS, power_w=[1.0 + 0.5 * (i % 7) for i in range(MAX_SEGMENTS)],
                           charge_to_percentage=math.nan)


def one_hour_plan():
    """3600 one-second segments of different loads (60 ms of a worker's CPU)."""
    return Predict.Request(duration_s=[1.0] * 3600, power_w=[1.0 + 0.5 * (i % 7) for i in range(3600)],
                           charge_to_percentage=math.nan)


#: a client's first predict is asked up to this many times, each waited for this long (an answer takes 0.1 s here)
FIRST_TRIES, FIRST_TRY_S = 5, 2.0


def first_answer(client):
    """How many asks it took until ``client``'s first predict was answered (None: FIRST_TRIES went unanswered).

    A synchronisation, not a measurement: wait_for_service sees the client's own endpoints matched to the server's,
    not the server's matched to the client's, and a request sent before the server knows the new client is lost by
    DDS (its reader is volatile), as is a response sent before the server's writer matches the client's reader
    (rmw_fastrtps drops it after 100 ms: 'failed to send response (timeout)'). A lost one never comes, so the test
    asks again rather than wait it out; the flood that follows is measured as before."""
    futures = []
    for tries in range(1, FIRST_TRIES + 1):
        futures.append(client.call_async(Predict.Request(duration_s=[1.0], power_w=[1.0])))
        if wait_until(lambda: any(future.done() for future in futures), FIRST_TRY_S):
            for future in futures:
                if not future.done():
                    client.remove_pending_request(future)
            return tries
    return None


def test_forty_predicts_at_once_are_each_answered_within_10_s(probe):
    """40 clients of one process ask one battery for one-hour plans at once: each is answered within 10 s, with the
    plan's answer or busy (success false, a message saying so). rmw_fastrtps delivers every response of the service
    to every client, and a client's response queue keeps the last 10. Before: 11 answered, 29 never (the service's
    request queue kept the last 10); then 29-39 of 40 (the server sent them all, the refusals in one burst: a client
    kept the last 10)."""
    process = NodeProcess('battery_sim', '-r', '__ns:=/forty')
    clients = []
    try:
        started(probe, '/forty', process)
        clients = [probe.node.create_client(Predict, '/forty/battery_simulator/predict')
                   for _ in range(PREDICTS_AT_ONCE)]
        assert all(client.wait_for_service(timeout_sec=10.0) for client in clients), 'predict not served'
        # each client is answered once, one at a time, before the flood (see first_answer)
        tries = [first_answer(client) for client in clients]
        assert None not in tries, 'a first predict of client %d unanswered in %d tries of %g s:\n%s' % (
            tries.index(None), FIRST_TRIES, FIRST_TRY_S, process.output())
        request = one_hour_plan()
        sent = time.monotonic()
        futures = [client.call_async(request) for client in clients]
        answered_at = {}
        while len(answered_at) < len(futures) and time.monotonic() < sent + ANSWER_WITHIN_S + 20.0:
            for index, future in enumerate(futures):
                if future.done() and index not in answered_at:
                    answered_at[index] = time.monotonic() - sent
            time.sleep(0.02)
        kinds = {}
        for index in answered_at:
            response = futures[index].result()
            kind = 'ok' if response.success else 'busy' if 'busy' in response.message else response.message
            kinds[kind] = kinds.get(kind, 0) + 1
        assert len(answered_at) == PREDICTS_AT_ONCE, '%d of %d answered within %g s (%s)' % (
            len(answered_at), PREDICTS_AT_ONCE, ANSWER_WITHIN_S + 20.0, kinds)
        assert set(kinds) <= {'ok', 'busy'}, 'answers other than the plan\'s or busy: %s' % kinds
        assert kinds.get('ok', 0) > 0, 'none answered with the plan: %s' % kinds
        late = sorted(seconds for seconds in answered_at.values() if seconds > ANSWER_WITHIN_S)
        assert not late, 'answered later than %g s: %s (%s)' % (ANSWER_WITHIN_S, late, kinds)
        print('forty: %s, the last answered at %.2f s (first predicts asked again: %d)' % (
            kinds, max(answered_at.values()), sum(tries) - len(tries)))
    finally:
        for client in clients:
            probe.node.destroy_client(client)
        stop_all(process)


FLOOD_CLIENTS = 16
CONTACT_TOGGLES = 8


def flood(service, clients):
    """A predict flood from a process of its own (its work is not the measurer's): ``clients`` clients ask
    ``service`` for the biggest plans, again as soon as answered, until SIGINT; 'asking' once they ask, the
    answers' counts (JSON) at the end, and 'answered' at the first answer."""
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    rclpy.init()
    node = rclpy.create_node('predict_flood')
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    stop = threading.Event()
    signal.signal(signal.SIGINT, lambda *_: stop.set())
    request = biggest_plan()
    counts = {'ok': 0, 'busy': 0, 'other': 0}
    pending = {}
    proxies = [node.create_client(Predict, service) for _ in range(clients)]
    for proxy in proxies:
        proxy.wait_for_service(timeout_sec=30.0)
    print('asking', flush=True)
    while not stop.is_set():
        for proxy in proxies:
            future = pending.get(proxy)
            if future is not None and future.done():
                response = future.result()
                counts['ok' if response.success else 'busy' if 'busy' in response.message else 'other'] += 1
                if sum(counts.values()) == 1:
                    print('answered', flush=True)
                future = None
            if future is None:
                pending[proxy] = proxy.call_async(request)
        executor.spin_once(timeout_sec=0.05)
    print(json.dumps(counts), flush=True)


def contact_delays(probe, ns, timeout_s=20.0):
    """charger_contact -> the status it asks for on ``ns``/battery_status, wall s, CONTACT_TOGGLES times, each
    waited for at most ``timeout_s``. (ROS 1's rostests have theirs, test/ros1/rostest_helpers.py: the same
    loop over rospy's publisher and Recorder, in another interpreter.)"""
    contact = probe.node.create_publisher(Bool, ns + '/charger_contact', 10)
    try:
        assert wait_until(lambda: contact.get_subscription_count() > 0, 20.0), ns + ' not on charger_contact'
        delays = []
        for index in range(CONTACT_TOGGLES):
            connected = index % 2 == 0
            since = time.monotonic()
            contact.publish(Bool(data=connected))
            msg = probe.wait_for(ns + '/battery_status', BatteryState,
                                 lambda m, c=connected: (m.power_supply_status == CHARGING) == c, timeout_s,
                                 since=since)
            assert msg is not None, '%s did not follow its contact within %g s' % (ns, timeout_s)
            delays.append(time.monotonic() - since)
            time.sleep(0.1 + 0.2 * random.random())
        return delays
    finally:
        probe.node.destroy_publisher(contact)


def test_a_predict_flood_does_not_starve_a_lone_battery(probe):
    """16 clients in another process flood a lone battery_sim with the biggest plans: its contact ->
    battery_status stays within max(0.25 s, 5 x) the same battery's without the flood, measured in this
    run (before: predict's coroutine held the node's callback group, 4.0 s median against 0.008 s)."""
    process = NodeProcess('battery_sim', '-r', '__ns:=/lone', '-p', 'time_scale:=1.0', '-p', 'initial_percentage:=50.0')
    flooder = None
    try:
        started(probe, '/lone', process)
        reference = contact_delays(probe, '/lone')
        flooder = subprocess.Popen([sys.executable, os.path.abspath(__file__), '--flood',
                                    '/lone/battery_simulator/predict',
                                    str(FLOOD_CLIENTS)], stdout=subprocess.PIPE, text=True)
        ready, _, _ = select.select([flooder.stdout], [], [], 40.0)
        assert ready and flooder.stdout.readline().strip() == 'asking', 'the flood did not start'
        time.sleep(2.0)   # the flood at full strength
        during = contact_delays(probe, '/lone')
        # every request is answered (a plan or busy) within ANSWER_WITHIN_S: on a busy machine the first answer
        # may come after the measurement, so wait for it (bounded) before ending the flood
        ready, _, _ = select.select([flooder.stdout], [], [], 2 * ANSWER_WITHIN_S)
        assert ready and flooder.stdout.readline().strip() == 'answered', 'no answer to the flood within %.0f s' % (
            2 * ANSWER_WITHIN_S)
        flooder.send_signal(signal.SIGINT)
        out, _ = flooder.communicate(timeout=40.0)
        counts = json.loads(out.strip().splitlines()[-1])
        bound = max(0.25, 5.0 * statistics.median(reference))
        print('contact -> status: %.3f s median alone, %.3f s under the flood (%s)' % (
            statistics.median(reference), statistics.median(during), counts))
        assert statistics.median(during) <= bound, \
            'contact -> status under a flood (%s): %s s; alone: %s s' % (
                counts, ['%.3f' % d for d in during], ['%.3f' % d for d in reference])
        assert counts['ok'] + counts['busy'] > 0, 'the flood was answered: %s' % counts
    finally:
        if flooder is not None and flooder.poll() is None:
            flooder.kill()
            flooder.wait()
        stop_all(process)


if __name__ == '__main__' and sys.argv[1:2] == ['--flood']:
    flood(sys.argv[2], int(sys.argv[3]))
