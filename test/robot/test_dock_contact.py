"""The demo's dock contact closes at the dock only (issue 40 item 8): the whole patrol path, every leg and
the way back from the dock, stays out of the contact's radius, and a whole cycle driven by the patrol rule
on the kinematic base (robot/patrol.py, robot/base.py, robot/dock_contact.py, as both ROS versions run
them) never closes the contact outside GO_TO_DOCK and CHARGING, at sim_clock's ticks for speed 60 and 240,
with a controller that now and then misses ticks (the base then holds its last command)."""
import math
import random

import pytest

from battery_simulator.robot import patrol as patrol_rule
from battery_simulator.robot.base import Base
from battery_simulator.robot.dock_contact import SETTINGS as CONTACT_SETTINGS, DockContact
from battery_simulator.robot.patrol import DEFAULT_WAYPOINTS, GO_TO_DOCK, CHARGING, GOAL_SUCCEEDED, PATROL, \
    Patrol, control_step

RADIUS_M = next(s.default for s in CONTACT_SETTINGS if s.name == 'radius')
MAX_SPEED = next(s.default for s in CONTACT_SETTINGS if s.name == 'max_speed')
DOCK = (0.0, 0.0)
START = (1.0, 0.0)   # demo.launch's fake_base x (off the dock)


def distance_to_segment(point, a, b):
    (px, py), (ax, ay), (bx, by) = point, a, b
    dx, dy = bx - ax, by - ay
    t = 0.0 if dx == dy == 0.0 else max(0.0, min(1.0, ((px - ax) * dx + (py - ay) * dy) / (dx * dx + dy * dy)))
    return math.hypot(ax + t * dx - px, ay + t * dy - py)


def test_every_leg_of_the_patrol_stays_out_of_the_contact_radius():
    """From the start, round the loop (the last waypoint back to the first included), with a margin of the
    waypoints' arrival distance and half a step of the base at speed 240."""
    loop = DEFAULT_WAYPOINTS + DEFAULT_WAYPOINTS[:1]
    legs = [(START, DEFAULT_WAYPOINTS[0])] + [(loop[k], loop[k + 1]) for k in range(len(DEFAULT_WAYPOINTS))]
    margin = patrol_rule.ARRIVED_M + 0.5 * 0.3 * 0.24
    for a, b in legs:
        assert distance_to_segment(DOCK, a, b) > RADIUS_M + margin, 'the leg %s -> %s passes the dock' % (a, b)


@pytest.mark.parametrize('tick_s', [0.06, 0.24, 0.6])   # sim_clock at speed 60 and 240 (1000 and 400 ticks/s)
@pytest.mark.parametrize('seed', range(8))
def test_a_cycle_closes_the_contact_only_at_the_dock(tick_s, seed):
    chooser = random.Random(seed)
    phases = []
    goal = []
    patrol = Patrol(DEFAULT_WAYPOINTS, DOCK[0], DOCK[1], 0.3, 0.6, phases.append, lambda: goal.append(True))
    base = Base(*START, cmd_vel_timeout=0.5)
    contact = DockContact(DOCK[0], DOCK[1], RADIUS_M, MAX_SPEED)
    now = 100.0
    base.step(now)
    last_control = now
    low_at = now + chooser.uniform(20.0, 60.0)   # the battery turns low somewhere on the loop
    charged_at = None
    patrol.start()
    closed = []
    stalled_until = now
    while now < 400.0 and len([p for p in phases if p == PATROL]) < 2:
        now += tick_s
        pose, (linear, _) = base.step(now)
        changed = contact.update(pose[0], pose[1], linear, 0.0)
        if changed is True:
            closed.append((patrol.phase, pose))
        if stalled_until > now:
            continue   # the controller misses ticks: the base holds its command up to its timeout, then stands
        if chooser.random() < 0.05:
            stalled_until = now + chooser.uniform(1.0, 30.0) * tick_s   # a loaded machine: 40-140 ms at 240x
            continue
        step = control_step(last_control, now)
        last_control = now
        outcome = None
        if patrol.phase == CHARGING:
            charged_at = charged_at or now
            outcome = GOAL_SUCCEEDED if now - charged_at > 10.0 else None
        command = patrol.control(pose, now >= low_at, contact.contact, step, outcome)
        base.command(*command, now)
    assert phases[:2] == [PATROL, GO_TO_DOCK] and PATROL in phases[2:], 'one whole cycle: %s' % phases
    away = [(phase, round(math.hypot(*pose[:2]), 3)) for phase, pose in closed if phase not in (GO_TO_DOCK, CHARGING)]
    assert not away, 'the contact closed away from the dock: %s' % away
    assert all(math.hypot(*pose[:2]) <= RADIUS_M for phase, pose in closed if phase == GO_TO_DOCK)


def test_a_robot_backing_off_the_dock_that_pauses_in_the_inner_half_stays_disconnected():
    """Issue 40 item 8 on the real demo (ROS 2 battery_demo at speed 240, load 20-30): the contact closed in 2
    of 5 cycles, during UNDOCK, with the rule of 87e33ef: the robot parked 0.12 m from the dock, backed off,
    and paused 0.135 m out (the inner half, where that rule closed the contact whatever the robot did)."""
    contact = DockContact(DOCK[0], DOCK[1], RADIUS_M, MAX_SPEED)
    assert contact.update(0.0, 0.20, -0.3, 0.0) is None        # arriving
    assert contact.update(0.0, 0.12, 0.0, 0.0) is True         # parked: connected
    assert contact.update(0.0, 0.135, 0.0, 0.15) is False      # backing off
    assert contact.update(0.0, 0.135, 0.0, 0.0) is None, 'a pause while leaving closed the contact'
    assert contact.update(0.0, 0.25, 0.0, 0.0) is None, 'nor further out'
    assert contact.update(0.0, 0.45, 0.0, 0.15) is None        # out of the radius
    assert contact.update(0.0, 0.12, 0.0, 0.0) is True, 'back on the dock: connected again'


def test_a_robot_nudged_by_a_few_centimetres_after_a_contact_is_connected_again():
    contact = DockContact(DOCK[0], DOCK[1], RADIUS_M, MAX_SPEED)
    assert contact.update(0.20, 0.0, 0.0, 0.0) is True
    assert contact.update(0.18, 0.0, -0.2, 0.0) is False       # seated a little further in
    assert contact.update(0.17, 0.0, 0.0, 0.0) is True


def test_a_robot_backing_off_past_the_centre_that_pauses_stays_disconnected():
    """The ROS 2 demo at speed 240 under load, with the rule "leaving = its distance growing": 3 contacts away
    from the dock in 4 cycles. A robot that docked turned sideways (it turned in place on the way in) backs off
    across the centre: its distance shrinks first, and a pause there closed the contact."""
    contact = DockContact(DOCK[0], DOCK[1], RADIUS_M, MAX_SPEED)
    assert contact.update(0.12, 0.0, 0.0, 0.0) is True         # docked
    assert contact.update(0.05, 0.0, -0.15, 0.0) is False      # backing off, towards the centre
    assert contact.update(0.04, 0.0, 0.0, 0.0) is None, 'a pause while leaving closed the contact'
    assert contact.update(-0.10, 0.0, 0.0, 0.0) is None


def test_a_robot_that_passed_the_centre_before_touching_still_connects():
    contact = DockContact(DOCK[0], DOCK[1], RADIUS_M, MAX_SPEED)
    for x, vx in ((0.25, -0.3), (0.05, -0.3), (-0.05, -0.3), (-0.10, -0.3)):
        assert contact.update(x, 0.0, vx, 0.0) is None
    assert contact.update(-0.11, 0.0, 0.0, 0.0) is True


def test_a_robot_that_stalled_on_its_way_in_connects_at_the_dock():
    """A stall in the outer half of the radius closes the contact (the robot stands there); driving on in, it
    was taken as leaving (moved more than LEAVING_M from where it touched), so at the dock it never connected
    again and the ROS 2 demo stayed in GO_TO_DOCK for 150 s."""
    contact = DockContact(DOCK[0], DOCK[1], RADIUS_M, MAX_SPEED)
    assert contact.update(0.28, 0.0, -0.3, 0.0) is None           # driving in
    assert contact.update(0.27, 0.0, 0.0, 0.0) is True            # a stall: it stands within the radius
    assert contact.update(0.20, 0.0, -0.3, 0.0) is False          # on, faster than max_speed
    assert contact.update(0.12, 0.0, 0.0, 0.0) is True, 'docked: the contact closes'
