"""The ROS 2 front end's hardening (issue 33, Part 4 items 10-18 and its low items): duplicates refused,
shutdown with a goal, state files, predict beside the batteries, parameters, the client, goal status.

Each process runs in a namespace of its own; every wait has a bound."""
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
from rcl_interfaces.srv import SetParametersAtomically
from rclpy.parameter import Parameter
from rclpy.time import Time
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import BatteryState
from std_msgs.msg import Bool

from battery_simulator.action import BatterySim
from battery_simulator.core.prediction import MAX_SEGMENTS
from battery_simulator.srv import Predict
from ros2_probe import LATCHED, NodeProcess, Probe

CHARGING = BatteryState.POWER_SUPPLY_STATUS_CHARGING


@pytest.fixture(scope='module')
def probe():
    probe = Probe('hardening_probe')
    yield probe
    probe.close()


def started(probe, ns, process, timeout_s=25.0):
    assert probe.wait_for(ns + '/battery_status', BatteryState, timeout_s=timeout_s) is not None, \
        'no %s/battery_status within %g s:\n%s' % (ns, timeout_s, process.output())


def stop_all(*processes):
    for process in processes:
        process.stop()


# -- item 10: one battery per name -------------------------------------------------------------------

@pytest.mark.parametrize('attempt', range(3))
def test_two_battery_sims_started_together_one_runs(probe, attempt):
    ns = '/dup%d' % attempt
    first = NodeProcess('battery_sim', '-r', '__ns:=' + ns, '-p', 'initial_percentage:=80.0')
    second = NodeProcess('battery_sim', '-r', '__ns:=' + ns, '-p', 'initial_percentage:=40.0')
    try:
        deadline = time.monotonic() + 15.0   # until one of them exits; then the other must stay
        while time.monotonic() < deadline and all(p.process.poll() is None for p in (first, second)):
            time.sleep(0.05)
        ended = [p for p in (first, second) if p.wait(1.0) is not None]
        assert len(ended) == 1, 'exactly one of two battery_sim in %s must exit (%d did):\n%s\n---\n%s' % (
            ns, len(ended), first.output(), second.output())
        loser = ended[0]
        assert loser.process.returncode != 0 and 'already served by' in loser.output() and \
            'Traceback' not in loser.output(), loser.output()
        survivor = second if loser is first else first
        started(probe, ns, survivor)
        assert survivor.process.poll() is None, survivor.output()
    finally:
        stop_all(first, second)


def test_two_battery_sims_started_after_five_others_find_each_other(probe):
    """Unicast discovery on 127.0.0.1 reaches the participants whose ids are below the profile's
    maxInitialPeersRange: with Fast DDS's default, 4, two processes started after the first four of a domain
    never met (both ran, 15 s)."""
    others = [NodeProcess('battery_sim', '-r', '__ns:=/crowd%d' % k) for k in range(5)]
    try:
        for k, other in enumerate(others):
            started(probe, '/crowd%d' % k, other)
        first = NodeProcess('battery_sim', '-r', '__ns:=/late')
        second = NodeProcess('battery_sim', '-r', '__ns:=/late')
        deadline = time.monotonic() + 15.0
        while time.monotonic() < deadline and all(p.process.poll() is None for p in (first, second)):
            time.sleep(0.05)
        ended = [p for p in (first, second) if p.wait(1.0) is not None]
        assert len(ended) == 1, 'two battery_sim in /late beside five others: %d exited:\n%s\n---\n%s' % (
            len(ended), first.output(), second.output())
        stop_all(first, second)
    finally:
        stop_all(*others)


def test_battery_sim_beside_a_fleet_host_serving_its_robot_exits(probe):
    fleet = NodeProcess('battery_fleet', '-p', 'robots:=2', '-p', 'prefix:=dupfleet')
    try:
        started(probe, '/dupfleet1', fleet)
        lone = NodeProcess('battery_sim', '-r', '__ns:=/dupfleet1')
        code = lone.wait(15.0)
        assert code not in (None, 0), 'battery_sim beside a fleet host serving dupfleet1 did not refuse:\n' + \
            lone.output()
        assert 'already served by /battery_fleet' in lone.output(), lone.output()
        assert fleet.process.poll() is None, 'the fleet host ended:\n' + fleet.output()
    finally:
        stop_all(fleet)


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


# -- item 12: a state_file that is not one, or cannot be written -------------------------------------

@pytest.mark.parametrize('executable', ['battery_sim', 'battery_fleet'])
def test_a_file_that_is_not_a_state_file_is_never_written_over(tmp_path, executable):
    user_file = tmp_path / 'my_robot_config.yaml'
    user_file.write_text('robot: {wheels: 4}\n')
    process = NodeProcess(executable, '-r', '__ns:=/notstate', '-p', 'state_file:=' + str(user_file))
    try:
        code = process.wait(15.0)
        assert code not in (None, 0), 'a non-state file was accepted:\n' + process.output()
        lines = [line for line in process.output().splitlines() if 'state_file' in line]
        assert len(lines) == 1 and 'is not a' in lines[0] and 'never written over' in lines[0], process.output()
    finally:
        stop_all(process)
    assert user_file.read_text() == 'robot: {wheels: 4}\n', 'the user\'s file was written over'


@pytest.mark.parametrize('path', ['/nonexistent_dir/x.json', '{tmp}'])
def test_an_unwritable_state_file_is_one_line_at_start(tmp_path, path):
    process = NodeProcess('battery_sim', '-r', '__ns:=/unwritable', '-p',
                          'state_file:=' + path.format(tmp=tmp_path))
    try:
        code = process.wait(15.0)
        assert code not in (None, 0), 'an unwritable state_file was accepted:\n' + process.output()
        lines = [line for line in process.output().splitlines() if line.strip()]
        assert len(lines) == 1 and 'state_file' in lines[0] and 'Traceback' not in process.output(), process.output()
    finally:
        stop_all(process)


# -- item 13: predict never delays the batteries -----------------------------------------------------

def test_a_predict_flood_does_not_delay_another_robot(probe):
    """4 clients flood robot0 of a fleet host with plans of the contract's most segments (100,000 power loads
    that differ, 6 s each: a week; 1.6 s of CPU each): robot1 follows its contact within 0.5 s (median) and robot2's
    battery_status keeps its 1 s period (within 0.2 s). Predict in the host's executor (the old design)
    made them 0.8 s and 1.6 s here (3.6 s and 1.8 s in the issue)."""
    fleet = NodeProcess('battery_fleet', '-p', 'robots:=3', '-p', 'prefix:=flood', '-p', 'time_scale:=1.0')
    stop = threading.Event()
    answered = []
    try:
        for robot in range(3):
            started(probe, '/flood%d' % robot, fleet)
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
        contact = probe.node.create_publisher(Bool, '/flood1/charger_contact', 10)
        delays = []
        for connected in (True, False, True, False, True, False, True, False):
            since = time.monotonic()
            contact.publish(Bool(data=connected))
            msg = probe.wait_for('/flood1/battery_status', BatteryState,
                                 lambda m, c=connected: (m.power_supply_status == CHARGING) == c, 10.0, since=since)
            assert msg is not None, 'robot1 did not follow its contact within 10 s during the flood'
            delays.append(time.monotonic() - since)
            stop.wait(0.3)
        stop.wait(max(0.0, measured_from + 6.0 - time.monotonic()))   # robot2's period over 6 s at least
        arrivals = [at for at, _ in list(status2) if at >= measured_from]
        period_s = (arrivals[-1] - arrivals[0]) / (len(arrivals) - 1) if len(arrivals) > 1 else math.inf
        during = answered[answered_before:]
        assert statistics.median(delays) < 0.5, 'contact -> status delays during a flood of robot0: %s' % \
            ', '.join('%.2f s' % delay for delay in delays)
        assert 0.8 <= period_s <= 1.2, "robot2's battery_status period during the flood: %.2f s (%d messages)" % (
            period_s, len(arrivals))
        # answered while measured: the plan's answers, or busy (on a loaded machine a plan of the most segments
        # takes its worker longer than a caller waits, 7 s: the worker goes on computing, the caller hears busy)
        assert len(during) > 0, 'the flood went on while measured (%d answers, %d successful)' % (
            len(during), sum(during))
    finally:
        stop.set()
        stop_all(fleet)


def wait_until(condition, timeout_s):
    deadline = time.monotonic() + timeout_s
    while not condition():
        if time.monotonic() > deadline:
            return False
        time.sleep(0.05)
    return True


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


# -- items 15 and 16: parameters ---------------------------------------------------------------------

@pytest.fixture(scope='module')
def sim(probe):
    process = NodeProcess('battery_sim', '-r', '__ns:=/hard', '-p', 'charging:=0', '-p', 'time_scale:=50.0')
    started(probe, '/hard', process)
    yield process
    assert process.stop() == 0, process.output()


def test_a_refused_atomic_set_changes_nothing(sim, probe):
    request = SetParametersAtomically.Request(parameters=[
        Parameter('charging', value=True).to_parameter_msg(), Parameter('time_scale', value=-1.0).to_parameter_msg()])
    result = probe.call(SetParametersAtomically, '/hard/battery_simulator/set_parameters_atomically', request).result
    assert not result.successful and 'time_scale' in result.reason, result
    since = time.monotonic() + 0.3
    msg = probe.wait_for('/hard/battery_status', BatteryState, timeout_s=5.0, since=since)
    assert msg is not None and msg.power_supply_status != CHARGING, 'a refused set started a charge'


@pytest.mark.parametrize('value,charging', [(1, True), (0, False), (True, True), (False, False)])
def test_charging_takes_1_0_true_false_at_run_time(sim, probe, value, charging):
    assert probe.set_parameter('/hard/battery_simulator', 'charging', value).successful
    msg = probe.wait_for('/hard/battery_status', BatteryState,
                         lambda m: (m.power_supply_status == CHARGING) == charging, 5.0, since=time.monotonic())
    assert msg is not None, 'charging := %r did not act' % value


@pytest.mark.parametrize('value', ['yes', 2, 0.5])
def test_charging_refuses_anything_else_naming_it(sim, probe, value):
    result = probe.set_parameter('/hard/battery_simulator', 'charging', value)
    assert not result.successful and 'charging' in result.reason, result


def test_time_scale_has_an_upper_bound(sim, probe):
    result = probe.set_parameter('/hard/battery_simulator', 'time_scale', 1e308)
    assert not result.successful and 'time_scale' in result.reason, result


@pytest.mark.parametrize('name, value, said', [
    ('undeclared_thing', 1.0, ['undeclared_thing', 'is not a parameter of /hard/battery_simulator', 'time_scale']),
    ('use_sim_time', 'x', ['use_sim_time', "'x'", 'true or false']),
    ('config', 'other.yaml', ['config', 'read at start only'])])
def test_rclpys_refusals_become_the_packages_reasons(sim, probe, name, value, said):
    """Low: rclpy's own texts ("Invalid access to undeclared parameter(s): []", "Wrong parameter type,
    expected '1' got '4'", "Trying to set a read-only parameter") become one line naming the parameter."""
    result = probe.set_parameter('/hard/battery_simulator', name, value)
    assert not result.successful, result
    for text in said:
        assert text in result.reason, 'no %r in the refusal: %s' % (text, result.reason)
    assert len(result.reason.splitlines()) == 1 and 'parameter(s)' not in result.reason, result.reason


@pytest.mark.parametrize('executable', ['battery_sim', 'battery_fleet'])
def test_an_empty_config_is_one_line_naming_it(executable):
    """Low: ``-p config:=`` (no value) was rcl's traceback."""
    process = NodeProcess(executable, '-r', '__ns:=/empty_config', '-p', 'config:=')
    try:
        assert process.wait(15.0) not in (None, 0), process.output()
        lines = [line for line in process.output().splitlines() if line.strip()]
        assert len(lines) == 1 and 'config' in lines[0] and 'Traceback' not in process.output(), process.output()
    finally:
        stop_all(process)


def test_a_lone_battery_state_pub_beside_a_fleet_robot_exits_naming_the_host(probe):
    """Low: battery_state_pub in /robotN while a fleet host serves robotN doubled its battery_status."""
    fleet = NodeProcess('battery_fleet', '-p', 'robots:=2', '-p', 'prefix:=lonepub')
    publisher = None
    try:
        started(probe, '/lonepub1', fleet)
        publisher = NodeProcess('battery_state_pub', '-r', '__ns:=/lonepub1')
        assert publisher.wait(20.0) not in (None, 0), 'battery_state_pub ran beside the fleet robot:\n' + \
            publisher.output()
        lines = [line for line in publisher.output().splitlines() if line.strip()]
        assert len(lines) == 1 and '/battery_fleet' in lines[0] and 'fleet host' in lines[0], publisher.output()
    finally:
        stop_all(*[p for p in (publisher, fleet) if p is not None])


@pytest.mark.parametrize('value,ok', [('1', True), ('true', True), ('0', True), ('maybe', False), ('2', False)])
def test_charging_at_start(probe, value, ok):
    ns = '/start_charging_%s' % value
    process = NodeProcess('battery_sim', '-r', '__ns:=' + ns, '-p', 'charging:=' + value)
    try:
        if ok:
            started(probe, ns, process)
        else:
            assert process.wait(15.0) not in (None, 0), process.output()
            lines = [line for line in process.output().splitlines() if line.strip()]
            assert len(lines) == 1 and 'charging' in lines[0], process.output()
    finally:
        stop_all(process)


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


def test_state_file_json_is_written(tmp_path, probe):
    """A state file given as a new path is written (the checks refuse only what they must)."""
    path = tmp_path / 'new.json'
    process = NodeProcess('battery_sim', '-r', '__ns:=/newstate', '-p', 'state_file:=' + str(path))
    try:
        started(probe, '/newstate', process)
        deadline = time.monotonic() + 10.0
        while not path.exists() and time.monotonic() < deadline:
            time.sleep(0.1)
        assert path.exists() and 'state_of_charge' in json.loads(path.read_text())
    finally:
        stop_all(process)


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
        time.sleep(max(0.0, killed_at - time.time()))
        killed_at = time.time()
        fleet.process.kill()
        level = 100.0 * (last.percentage - rate * (killed_at - stamp(last)))
    finally:
        fleet.stop(signal.SIGKILL)
    again = NodeProcess('battery_fleet', *args)
    try:
        assert again.wait_for_output('resumed from', 20.0), again.output()
        line = next(line for line in again.output().splitlines() if 'resumed from' in line)
        resumed = float(line.split('resumed from')[1].split(':')[1].split('%')[0])
        allowed = 1.0 + 100.0 * rate * lateness_s
        assert abs(resumed - level) <= allowed, 'killed at %.2f %%, resumed at %.1f %% (allowed %.2f: deliveries up to ' \
            '%.3f s late here):\n%s' % (level, resumed, allowed, lateness_s, line)
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


def test_forty_predicts_at_once_are_each_answered_within_10_s(probe):
    """40 clients ask one battery for one-hour plans at once: each is answered within 10 s, with the plan's
    answer or busy
    (success false, a message saying so). Before: 11 answered, 29 never (the service's request queue kept
    the last 10)."""
    process = NodeProcess('battery_sim', '-r', '__ns:=/forty')
    clients = []
    try:
        started(probe, '/forty', process)
        clients = [probe.node.create_client(Predict, '/forty/battery_simulator/predict')
                   for _ in range(PREDICTS_AT_ONCE)]
        assert all(client.wait_for_service(timeout_sec=10.0) for client in clients), 'predict not served'
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


def contact_delays(probe, ns):
    """charger_contact -> the status it asks for on ``ns``/battery_status, wall s, CONTACT_TOGGLES times."""
    contact = probe.node.create_publisher(Bool, ns + '/charger_contact', 10)
    try:
        assert wait_until(lambda: contact.get_subscription_count() > 0, 20.0), ns + ' not on charger_contact'
        delays = []
        for index in range(CONTACT_TOGGLES):
            connected = index % 2 == 0
            since = time.monotonic()
            contact.publish(Bool(data=connected))
            msg = probe.wait_for(ns + '/battery_status', BatteryState,
                                 lambda m, c=connected: (m.power_supply_status == CHARGING) == c, 20.0, since=since)
            assert msg is not None, '%s did not follow its contact within 20 s' % ns
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


# -- issue 40 item 7: one battery per state file ------------------------------------------------------

def test_a_second_battery_given_a_state_file_in_use_is_refused_naming_the_holder(probe, tmp_path):
    """Two battery_sims given one state_file: the second ends at start (exit 2) with one line naming the file
    and the battery that holds it (before: it "resumed from shared.json" the first one's state, and both
    wrote it). A holder killed with SIGKILL leaves nothing that blocks its restart; a fleet's file likewise."""
    path = str(tmp_path / 'shared.json')
    first = NodeProcess('battery_sim', '-r', '__ns:=/s1', '-p', 'state_file:=' + path)
    second = again = None
    try:
        started(probe, '/s1', first)
        second = NodeProcess('battery_sim', '-r', '__ns:=/s2', '-p', 'state_file:=' + path,
                             '-p', 'initial_percentage:=30.0')
        assert second.wait(30.0) == 2, second.output()
        lines = [line for line in second.output().splitlines() if path in line]
        assert len(lines) == 1 and '/s1' in lines[0], second.output()
        first.process.kill()
        first.wait(10.0)
        again = NodeProcess('battery_sim', '-r', '__ns:=/s1', '-p', 'state_file:=' + path)
        started(probe, '/s1', again)
        assert again.process.poll() is None, again.output()
    finally:
        stop_all(*(p for p in (first, second, again) if p is not None))
    fleet_file = str(tmp_path / 'fleet.json')
    fleet = NodeProcess('battery_fleet', '-p', 'robots:=1', '-p', 'prefix:=held', '-p', 'state_file:=' + fleet_file)
    other = None
    try:
        started(probe, '/held0', fleet)
        other = NodeProcess('battery_fleet', '-r', '__node:=battery_fleet_1', '-p', 'robots:=1', '-p', 'first:=1',
                            '-p', 'prefix:=held', '-p', 'state_file:=' + fleet_file)
        assert other.wait(30.0) == 2, other.output()
        assert '/battery_fleet ' in other.output() and fleet_file in other.output(), other.output()
    finally:
        stop_all(*(p for p in (fleet, other) if p is not None))


# -- issue 40 item 8: connect and disconnect are both said ----------------------------------------------

def test_every_connect_and_disconnect_is_logged_none_throttled(probe):
    """The demo's robot touched the dock for 40-140 ms: the battery said "charger connected", and the
    "disconnected" after it fell under a 1 s throttle (later: one throttle a state, so connect, disconnect,
    connect within a second still lost the second connect). Every change is said: at once when the state
    before it stood core/battery_log.SETTLE_S, else counted as a bounce and said, with the state it ended in,
    once the contact stands (a bouncing contact writes about a line a second, not a line a change)."""
    process = NodeProcess('battery_sim', '-r', '__ns:=/flick', '-p', 'initial_percentage:=50.0')
    contact = probe.node.create_publisher(Bool, '/flick/charger_contact', 10)
    try:
        started(probe, '/flick', process)
        assert wait_until(lambda: contact.get_subscription_count() > 0, 20.0), 'not on charger_contact'
        for connected in (True, False, True):
            since = time.monotonic()
            contact.publish(Bool(data=connected))
            assert probe.wait_for('/flick/battery_status', BatteryState,
                                  lambda m: (m.power_supply_status == CHARGING) == connected, 10.0,
                                  since=since) is not None
        assert process.wait_for_output('charger contact: charger connected (after 2 change(s)', 10.0), \
            process.output()
        lines = [line for line in process.output().splitlines() if 'charger contact: charger' in line]
        assert len(lines) == 2 and lines[0].endswith('charger contact: charger connected'), lines
    finally:
        probe.node.destroy_publisher(contact)
        stop_all(process)
