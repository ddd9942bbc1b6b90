"""The robot's loop without ROS (robot/): the cut-off gate's rule, contact from a pose, the patrol-and-dock
phases over a whole cycle on a coarse clock, the clock's tick policy, the base's steps, the settings."""
import math

import pytest

from battery_simulator.core.node_settings import SettingError, check_setting
from battery_simulator.robot import base, clock, cmd_vel_gate, dock_contact, patrol

NAN, INF = math.nan, math.inf


def test_the_gate_stops_once_at_empty_and_drops_until_it_is_not():
    gate = cmd_vel_gate.CmdVelGate()
    assert gate.on_command((0.3, 0, 0, 0, 0, 0.1)) == cmd_vel_gate.FORWARD
    assert gate.on_state('Discharging') is None, 'no change, no stop'
    assert gate.on_state('Empty') == 'empty'
    assert gate.on_state('Empty') is None, 'one stop per empty, not one per state'
    assert gate.on_command((0.3, 0, 0, 0, 0, 0.1)) == cmd_vel_gate.DROP
    assert gate.on_state('Charging') == 'not empty'
    assert gate.on_command((0.3, 0, 0, 0, 0, 0.1)) == cmd_vel_gate.FORWARD


def test_the_gate_never_relays_a_non_finite_command_and_stops_once_per_run_of_them():
    gate = cmd_vel_gate.CmdVelGate()
    assert gate.on_command((NAN, 0, 0, 0, 0, 0)) == cmd_vel_gate.STOP
    assert gate.on_command((0, 0, 0, 0, 0, INF)) == cmd_vel_gate.BAD, 'the stop went out already'
    assert gate.on_command((0.1, 0, 0, 0, 0, 0)) == cmd_vel_gate.FORWARD
    assert gate.on_command((0, -INF, 0, 0, 0, 0)) == cmd_vel_gate.STOP, 'a new run of bad commands stops again'
    assert 'nan' in cmd_vel_gate.bad_command_line((NAN, 0, 0, 0, 0, 0))


def test_contact_needs_the_robot_near_the_dock_and_slow():
    contact = dock_contact.DockContact(1.0, 2.0, 0.3, 0.05)
    assert contact.update(0.0, 0.0, 0.0, 0.0) is None, 'false from the start: no change'
    assert contact.update(1.1, 2.1, 0.2, 0.0) is None, 'near but too fast'
    assert contact.update(1.1, 2.1, 0.01, 0.0) is True
    assert contact.update(1.1, 2.1, 0.0, 0.0) is None, 'only changes are reported'
    assert contact.update(1.5, 2.0, 0.0, 0.0) is False, 'beyond the radius'
    with pytest.raises(ValueError, match='non-finite'):
        contact.update(NAN, 2.0, 0.0, 0.0)
    assert contact.contact is False, 'a bad odometry changes nothing'


def test_the_base_moves_only_over_ros_time_that_passed():
    robot = base.Base(1.0, 0.0, 0.0, cmd_vel_timeout=0.5)
    assert robot.step(0.0)[0] == (1.0, 0.0, 0.0), 'no clock yet: a start'
    assert robot.step(10.0)[0] == (1.0, 0.0, 0.0), 'the first time seen is a start, not elapsed time'
    assert robot.command(0.5, 0.0, 10.0)
    pose, moving = robot.step(10.24)
    assert pose == pytest.approx((1.12, 0.0, 0.0)) and moving == (0.5, 0.0)
    assert robot.step(10.24) is None, 'ROS time did not move: nothing to publish'
    pose, _ = robot.step(5.0)
    assert pose == pytest.approx((1.12, 0.0, 0.0)), 'a jump back moves nothing'
    assert not robot.command(NAN, 0.0, 5.0) and not robot.command(0.1, INF, 5.0), 'non-finite commands refused'


def test_a_command_holds_one_and_a_half_ticks_of_a_coarse_clock_but_not_a_stall():
    robot = base.Base(cmd_vel_timeout=0.5)
    robot.step(1.0)
    for tick in range(1, 4):   # 0.96 s ticks (speed 240 at 250 Hz), a command each tick
        robot.command(0.1, 0.0, 1.0 + 0.96 * (tick - 1))
        pose, moving = robot.step(1.0 + 0.96 * tick)
        assert moving == (0.1, 0.0), 'a 0.5 s timeout must not stop a robot commanded every 0.96 s tick'
    assert pose[0] == pytest.approx(0.1 * 3 * 0.96)
    pose, moving = robot.step(100.0)
    assert moving == (0.0, 0.0) and pose[0] == pytest.approx(0.1 * (2 * 0.96 + 1.44)), \
        'a stall: the last command (at 2.92 s) holds 1.5 ticks, not until 100 s'


def test_the_clock_ticks_on_schedule_and_gives_up_catching_up_when_far_behind():
    schedule = clock.TickSchedule(240.0, 100.0, 250.0, wall_now=0.0)
    assert schedule.tick() == pytest.approx(100.96)
    assert schedule.delay(0.001) == (pytest.approx(0.003), False)
    assert schedule.tick() == pytest.approx(101.92)
    assert schedule.delay(0.05) == (0.0, False), 'a little late: catch up, no sleep'
    schedule.tick()
    assert schedule.delay(0.5) == (0.0, True), 'far behind: give up, ROS time runs slower'
    schedule.tick()
    assert schedule.delay(0.5) == (pytest.approx(0.004), False), 'and the schedule restarts from then'
    assert 'x240' in schedule.start_line() and '3840 ms' not in schedule.start_line()


def test_the_clock_stops_at_the_largest_ros_time():
    schedule = clock.TickSchedule(1.0, clock.MAX_ROS_TIME_S - 0.5, 1000.0, wall_now=0.0)
    for _ in range(400):
        schedule.tick()
    with pytest.raises(clock.ClockTooFar):
        for _ in range(1000):
            schedule.tick()
    assert '4294967295' in clock.too_far_line('~start')


@pytest.mark.parametrize('value, pairs', [
    ([[1, 0], [2.5, -1]], [(1.0, 0.0), (2.5, -1.0)]),
    ([1, 0, 2.5, -1], [(1.0, 0.0), (2.5, -1.0)]),      # ROS 2: a flat list of doubles
    ([], None), ([1, 0, 2], None), ([[1, 0], [2]], None), ('1,0', None), ([[1, NAN]], None), ([True, 0], None)])
def test_waypoints_as_pairs_or_a_flat_list(value, pairs):
    assert patrol.waypoint_pairs(value) == pairs


@pytest.mark.parametrize('settings, name, value', [
    (base.SETTINGS, 'rate', 0.0), (base.SETTINGS, 'cmd_vel_timeout', -1.0), (base.SETTINGS, 'odom_frame', ''),
    (dock_contact.SETTINGS, 'radius', 0.0), (dock_contact.SETTINGS, 'dock_x', 'near'),
    (patrol.SETTINGS, 'speed', 0.0), (patrol.SETTINGS, 'waypoints', [[1.0]]),
    (clock.SETTINGS, 'speed', 20000.0), (clock.SETTINGS, 'tick_hz', 0.0), (clock.SETTINGS, 'wait_for', ['']),
    (clock.SETTINGS, 'wait_for', ['bad topic!']), (clock.SETTINGS, 'wait_for', ['odom', '2nd/odom']),
    (clock.SETTINGS, 'start', -1.0)])
def test_bad_settings_are_refused_naming_the_value_and_what_is_allowed(settings, name, value):
    setting = next(s for s in settings if s.name == name)
    check_setting(setting, setting.default)
    with pytest.raises(SettingError, match=r'parameter %s = .* is invalid: must be ' % name):
        check_setting(setting, value)


def run_cycle(step_s, low_at_step=100, full_after_steps=20, steps=3000):
    """Patrol, base and contact over a coarse clock: [(phase, step)] (the battery is a pair of step counts)."""
    phases, goals = [], []
    behaviour = patrol.Patrol(patrol.DEFAULT_WAYPOINTS, 0.0, 0.0, 0.3, 0.6,
                              lambda phase: phases.append((phase, step)), lambda: goals.append(step))
    contact = dock_contact.DockContact(0.0, 0.0, 0.3, 0.05)
    robot = base.Base(1.0, 0.0, 0.0, 0.5)
    robot.step(1.0)
    step = 0
    behaviour.start()
    moving = (0.0, 0.0)
    for step in range(1, steps):
        now = 1.0 + step * step_s
        low = low_at_step <= step and not any(p == patrol.CHARGING for p, _ in phases)
        outcome = patrol.GOAL_SUCCEEDED if goals and step - goals[-1] >= full_after_steps else None
        command = behaviour.control(robot.pose, low, contact.contact, step_s, outcome)
        robot.command(*command, now - step_s)
        pose, moving = robot.step(now)
        contact.update(pose[0], pose[1], moving[0] * math.cos(pose[2]), moving[0] * math.sin(pose[2]))
        if [p for p, _ in phases][-2:] == [patrol.UNDOCK, patrol.PATROL]:
            break
    return phases, goals, robot.pose


@pytest.mark.parametrize('step_s', [0.05, 0.24, 0.96])
def test_a_whole_cycle_patrols_docks_charges_undocks_and_patrols_again(step_s):
    phases, goals, pose = run_cycle(step_s)
    assert [p for p, _ in phases] == ['PATROL', 'GO_TO_DOCK', 'CHARGING', 'UNDOCK', 'PATROL'], phases
    assert len(goals) == 1, 'one charge goal, sent on contact'
    assert 0.6 - patrol.ARRIVED_M <= math.hypot(*pose[:2]) <= 0.6 + 0.3, 'backed off the dock'


def test_a_failed_charge_goal_is_sent_again():
    goals, phases = [], []
    behaviour = patrol.Patrol([[1, 0]], 0.0, 0.0, 0.3, 0.6, phases.append, lambda: goals.append(1))
    behaviour.phase = patrol.GO_TO_DOCK
    assert behaviour.control((0.0, 0.0, 0.0), True, True, 0.05) == (0.0, 0.0)
    assert behaviour.control((0.0, 0.0, 0.0), True, True, 0.05, patrol.GOAL_FAILED) == (0.0, 0.0)
    assert len(goals) == 2 and phases == [patrol.CHARGING]


@pytest.mark.parametrize('last, now, step', [(1.0, 1.0, None), (1.0, 1.96, 0.96), (1.0, 1.01, 0.05),
                                             (10.0, 9.5, None), (10.0, 2.0, 0.05)])
def test_a_control_step_comes_only_when_ros_time_moved(last, now, step):
    assert patrol.control_step(last, now) == (pytest.approx(step) if step else None)
