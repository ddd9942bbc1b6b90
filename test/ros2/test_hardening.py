"""The ROS 2 front end's hardening (issue 33, Part 4 items 10-18 and its low items; issue 40 items 7-8):
duplicates refused, state files, parameters, start-up values, the charger's log lines. What measures time
(a stop during a goal, predict beside the batteries, two clocks, the client, a fleet killed at x300) is
test_hardening_timing.py's: a ctest target of its own, holding the "timing" lock, while this one runs beside
the others.

Each process runs in a namespace of its own; every wait has a bound."""
import json
import time

import pytest
from rcl_interfaces.srv import SetParametersAtomically
from rclpy.parameter import Parameter
from sensor_msgs.msg import BatteryState
from std_msgs.msg import Bool

from ros2_probe import NodeProcess, Probe

CHARGING = BatteryState.POWER_SUPPLY_STATUS_CHARGING


@pytest.fixture(scope='module')
def probe():
    probe = Probe('hardening_probe')
    yield probe
    probe.close()


def started(probe, ns, process, timeout_s=25.0):
    assert probe.wait_for(ns + '/battery_status', BatteryState, timeout_s=timeout_s) is not None, \
        'no %s/battery_status within %g s:\n%s' % (ns, timeout_s, process.output())


def refusal_exit(process, name, start_s=60.0, exit_s=15.0):
    """The exit status of a process that refuses a start-up value: its line naming ``name`` within ``start_s``
    (an import on a loaded machine takes seconds), then its exit within ``exit_s``; None if it did not end."""
    process.wait_for_output(name, start_s)
    return process.wait(exit_s)


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
    others = [NodeProcess('battery_sim', '-r', '__ns:=/crowd%d' % k) for k in range(5)]   # started together
    try:
        for k, other in enumerate(others):
            started(probe, '/crowd%d' % k, other, timeout_s=60.0)
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


# -- item 12: a state_file that is not one, or cannot be written -------------------------------------

@pytest.mark.parametrize('executable', ['battery_sim', 'battery_fleet'])
def test_a_file_that_is_not_a_state_file_is_never_written_over(tmp_path, executable):
    user_file = tmp_path / 'my_robot_config.yaml'
    user_file.write_text('robot: {wheels: 4}\n')
    process = NodeProcess(executable, '-r', '__ns:=/notstate', '-p', 'state_file:=' + str(user_file))
    try:
        code = refusal_exit(process, 'state_file')
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
        code = refusal_exit(process, 'state_file')
        assert code not in (None, 0), 'an unwritable state_file was accepted:\n' + process.output()
        lines = [line for line in process.output().splitlines() if line.strip()]
        assert len(lines) == 1 and 'state_file' in lines[0] and 'Traceback' not in process.output(), process.output()
    finally:
        stop_all(process)


def wait_until(condition, timeout_s):
    deadline = time.monotonic() + timeout_s
    while not condition():
        if time.monotonic() > deadline:
            return False
        time.sleep(0.05)
    return True


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
        assert refusal_exit(process, 'config') not in (None, 0), process.output()
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
            assert refusal_exit(process, 'charging') not in (None, 0), process.output()
            lines = [line for line in process.output().splitlines() if line.strip()]
            assert len(lines) == 1 and 'charging' in lines[0], process.output()
    finally:
        stop_all(process)


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
