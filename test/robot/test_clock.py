"""The demo robot on a coarse ROS clock (no ROS): sim_clock's tick arithmetic (robot/clock.py), fake_base's
integration over the ROS time that passed (robot/base.py), patrol_and_dock's step-limited commands
(robot/patrol.py); and patrol_and_dock's fresh-pose rule in its ROS 1 adapter (needs the devel space)."""
import math

import pytest

from battery_simulator.core.time_base import TimeBase

from battery_simulator.robot import base as fake_base
from battery_simulator.robot import clock as sim_clock
from battery_simulator.robot import patrol


def test_ros_time_is_counted_in_ticks_so_it_never_drifts():
    assert sim_clock.tick_time(0.0, 240.0, 1000.0, 1) == pytest.approx(0.24)
    assert sim_clock.tick_time(100.0, 60.0, 250.0, 250 * 3600) == pytest.approx(100.0 + 60.0 * 3600.0, abs=1e-6)


def test_a_held_twist_integrates_the_same_in_coarse_steps_as_in_one():
    command = (0.3, 0.4, 0.0)   # received at t = 0, held (timeout far away)
    pose = (1.0, 0.0, 0.0)
    for step in range(10):
        pose, moving = fake_base.advance(pose, command, 0.24 * step, 0.24 * (step + 1), 100.0)
        assert moving
    once, _ = fake_base.advance((1.0, 0.0, 0.0), command, 0.0, 2.4, 100.0)
    assert pose == pytest.approx(once, abs=1e-12)
    assert once == pytest.approx(fake_base.integrate(1.0, 0.0, 0.0, 0.3, 0.4, 2.4))


def test_a_command_stops_at_its_timeout_within_a_step():
    pose, moving = fake_base.advance((0.0, 0.0, 0.0), (0.5, 0.0, 1.0), 1.0, 2.0, 0.5)
    assert pose == pytest.approx((0.25, 0.0, 0.0)) and not moving   # drove 0.5 s of the 1 s step
    pose, moving = fake_base.advance((0.0, 0.0, 0.0), (0.5, 0.0, 1.0), 3.0, 4.0, 0.5)
    assert pose == (0.0, 0.0, 0.0) and not moving                    # long timed out


@pytest.mark.parametrize('step_s', [0.05, 0.24, 0.96, 5.0])
def test_no_command_drives_or_turns_past_its_goal_within_a_step(step_s):
    for goal in ((0.05, 0.0), (0.3, 0.01), (2.0, 0.0)):
        linear, angular = patrol.drive_to(0.0, 0.0, 0.0, goal[0], goal[1], 0.6, step_s)
        assert 0.0 <= linear * step_s <= 0.5 * math.hypot(*goal) + 1e-12
        heading = math.atan2(goal[1], goal[0])
        assert abs(angular * step_s) <= 0.5 * abs(heading) + 1e-12


def test_the_clock_holds_until_every_named_topic_has_a_publisher():
    published = [('/odom', 'nav_msgs/Odometry'), ('/battery_status', 'sensor_msgs/BatteryState')]
    assert sim_clock.missing_publishers(['/odom', '/patrol_and_dock/phase'], published) == ['/patrol_and_dock/phase']
    assert sim_clock.missing_publishers(['/odom', '/battery_status'], published) == []


def _behaviour_with_pose(pose_stamp_s, commanded_at_s):
    """A ROS 1 PatrolAndDock without a master: just the inputs that _fresh_inputs reads."""
    import threading
    ros1_patrol = pytest.importorskip('battery_simulator.ros1.patrol_and_dock', reason='needs the devel space')
    behaviour = ros1_patrol.PatrolAndDock.__new__(ros1_patrol.PatrolAndDock)
    behaviour._lock = threading.Lock()
    behaviour._pose_arrived = threading.Condition(behaviour._lock)
    behaviour._pose, behaviour._low, behaviour._contact = (1.0, 2.0, 0.0), True, False
    behaviour._pose_stamp_s, behaviour._commanded_at_s = pose_stamp_s, commanded_at_s
    return behaviour


def test_a_pose_the_last_command_has_not_moved_is_not_steered_again(monkeypatch):
    # odometry queued seconds late on a starved machine: steering it again turned the robot in circles
    ros1_patrol = pytest.importorskip('battery_simulator.ros1.patrol_and_dock', reason='needs the devel space')
    monkeypatch.setattr(ros1_patrol, 'FRESH_POSE_WAIT_S', 0.01)
    assert _behaviour_with_pose(10.0, 10.0)._fresh_inputs() == (None, True, False)
    assert _behaviour_with_pose(9.4, 10.0)._fresh_inputs() == (None, True, False)
    assert _behaviour_with_pose(10.6, 10.0)._fresh_inputs() == ((1.0, 2.0, 0.0), True, False)


@pytest.mark.parametrize('step_s', [0.05, 0.24, 0.96])
def test_undocking_ends_although_each_step_drives_half_the_way_left(step_s):
    entered = []
    behaviour = patrol.Patrol(patrol.DEFAULT_WAYPOINTS, 0.0, 0.0, 0.3, 0.6, entered.append, lambda: None)
    behaviour.phase, behaviour.undock_from = patrol.UNDOCK, patrol.undock_goal(0.0, 0.0, 0.0, 0.0, 0.0, 0.6, (0.0, 0.0))
    pose = (0.0, 0.0, 0.0)
    for _ in range(200):
        linear, angular = behaviour.control(pose, False, False, step_s)
        if entered:
            break
        pose, _ = fake_base.advance(pose, (linear, angular, 0.0), 0.0, step_s, 100.0)
    assert entered == [patrol.PATROL]
    assert 0.6 - patrol.ARRIVED_M <= math.hypot(*pose[:2]) <= 0.6


def test_a_forward_jump_beyond_the_bound_restarts_the_time_base():
    base = TimeBase(1.0, zero_is_unset=True, max_jump_s=3600.0)
    assert base.elapsed(1000.0) == 0.0                       # a start
    assert base.elapsed(1100.0) == 100.0                     # an honest step (speed 1000, 10 Hz)
    assert base.elapsed(49000.0) == 0.0 and base.jumps_forward == 1   # a second clock: drains nothing
    assert base.elapsed(1100.1) == 0.0 and base.jumps_back == 1       # and back: nothing either
    assert base.pending(60000.0) == 0.0, 'a prediction does not count a jump either'
    assert base.elapsed(1103.1) == 3.0 and base.restarts == 2


def test_no_bound_without_one():
    base = TimeBase(1.0)
    base.elapsed(0.5)
    assert base.elapsed(1e6) == 1e6 - 0.5 and base.restarts == 0


def test_the_pace_waits_for_every_topic_since_the_last_tick():
    """Issue 40 items 8 and 15: sim_clock paced on the robot's cmd_vel moves ROS time a tick only once the
    controller answered the last one (its front ends wait at most PACE_WAIT_S for it)."""
    from battery_simulator.robot.clock import PACE_WAIT_S, Pace
    pace = Pace(['/cmd_vel', '/odom'])
    assert pace.ready(), 'the first tick waits for nothing'
    pace.ticked()
    assert not pace.ready()
    pace.heard('/cmd_vel')
    assert not pace.ready(), 'one of two topics'
    pace.heard('/odom')
    assert pace.ready()
    pace.ticked()
    assert not pace.ready(), 'a message before the tick does not count for the next'
    assert Pace([]).ready() and 0.0 < PACE_WAIT_S <= 1.0


@pytest.mark.parametrize('start', [(0.0, 0.12, 0.0), (-0.05, -0.02, 2.8), (0.0, -0.1, 1.57)])
@pytest.mark.parametrize('step_s', [0.05, 0.24, 0.6])
def test_a_robot_that_turned_on_the_dock_backs_off_away_from_it(step_s, start):
    """Issue 40 item 8 on the real demo (ROS 2 battery_demo at speed 240, load 20-30): the contact closed on
    patrol 3 times in 4 cycles. A robot that turned on the dock (parked 0.12 m north of it, facing east)
    backed off along its heading, across the dock to its west, and the patrol back east to the first
    waypoint crossed the contact's radius (and one that stopped past the centre, backing off away from the
    dock, did the same). It backs off to the first waypoint's side of the dock, and the way on stays out."""
    entered = []
    behaviour = patrol.Patrol(patrol.DEFAULT_WAYPOINTS, 0.0, 0.0, 0.3, 0.6, entered.append, lambda: None)
    behaviour.phase, behaviour.rested_s = patrol.CHARGING, 0.0
    pose = start   # turned on the dock; stopped past its centre (as seen on the demo); south of it
    for _ in range(400):
        linear, angular = behaviour.control(pose, False, False, step_s, patrol.GOAL_SUCCEEDED)
        if patrol.PATROL in entered:
            break
        pose, _ = fake_base.advance(pose, (linear, angular, 0.0), 0.0, step_s, 100.0)
    assert entered == [patrol.UNDOCK, patrol.PATROL], entered
    assert math.hypot(*pose[:2]) > 0.3, 'undocked within the radius: %s' % (pose,)
    first = patrol.DEFAULT_WAYPOINTS[0]
    # the leg on to the first waypoint, from where the undocking ended, keeps out of the radius (0.3 m)
    dx, dy = first[0] - pose[0], first[1] - pose[1]
    t = max(0.0, min(1.0, -(pose[0] * dx + pose[1] * dy) / (dx * dx + dy * dy)))
    assert math.hypot(pose[0] + t * dx, pose[1] + t * dy) > 0.3, 'the way on passes the dock from %s' % (pose,)


def test_a_paced_clock_behind_says_it_waits_for_the_controller():
    free = sim_clock.TickSchedule(240.0, 0.0, 250.0, 0.0)
    assert free.behind_line() == 'sim_clock cannot keep up 250 ticks a second: ROS time runs slower than x240'
    paced = sim_clock.TickSchedule(240.0, 0.0, 250.0, 0.0, ['/cmd_vel'])
    assert paced.behind_line() == ('sim_clock paced on /cmd_vel: ROS time runs slower than x240 while the '
                                   'controller takes longer than a tick (4 ms)')
