"""patrol_and_dock's rest_on_dock (issue 43: the demo with a learning gauge rests on the dock once full, where
the gauge reads the rest): the robot stays in CHARGING for that much ROS time after the goal ended Full. And a
robot standing on the dock without the contact backs off and docks again (issue 40 item 8)."""
import pytest

from battery_simulator.robot import demo_gauges, patrol


def charged(rest_on_dock, told_once):
    """(the ROS time from Full to UNDOCK, the phases) with 0.5 s control steps; the front ends tell the goal's
    end at every step after it (ROS 1: the action client's state), or once."""
    phases = []
    behaviour = patrol.Patrol([[1, 0]], 0.0, 0.0, 0.3, 0.6, phases.append, lambda: None, rest_on_dock)
    behaviour.phase = patrol.CHARGING
    outcome, waited = patrol.GOAL_SUCCEEDED, 0.0
    while behaviour.phase == patrol.CHARGING and waited < 10000.0:
        assert behaviour.control((0.0, 0.0, 0.0), False, True, 0.5, outcome) == (0.0, 0.0)
        outcome = None if told_once else outcome
        waited += 0.5
    return waited - 0.5, phases


@pytest.mark.parametrize('told_once', [True, False])
@pytest.mark.parametrize('rest_on_dock', [0.0, 2400.0])
def test_the_robot_rests_on_the_dock_once_full_for_rest_on_dock_seconds(rest_on_dock, told_once):
    """The ROS 1 demo with rest_on_dock stayed on the dock for good: its front end tells the goal's end at
    every step, and each restarted the rest."""
    waited, phases = charged(rest_on_dock, told_once)
    assert waited == pytest.approx(rest_on_dock, abs=0.5) and phases == [patrol.UNDOCK]


def test_the_demo_rests_with_a_learning_gauge_only():
    assert demo_gauges.rest_on_dock_s('impedance_track') >= 1800.0 + 300.0, 'past the gauge\'s 30 min rest'
    assert demo_gauges.rest_on_dock_s('modelgauge') >= 2880.0 + 300.0, 'past its 48 min'
    assert demo_gauges.rest_on_dock_s('ideal') == demo_gauges.rest_on_dock_s('realistic') == 0.0
    assert set(demo_gauges.GAUGE_CONFIGS) == {'ideal', 'realistic', 'impedance_track', 'modelgauge'}


def test_a_robot_standing_on_the_dock_without_the_contact_backs_off_and_docks_again():
    """The ROS 2 demo at speed 240 under two CPU hogs: the robot touched the contact at (0.05, 0.15) on its way
    in, a late controller carried it across the dock to (-0.01, -0.13), where battery_dock_contact took it as
    leaving (moved more than 5 cm from where it touched) and patrol_and_dock as docked (within DOCKED_M): it
    stood there without the contact until the battery was empty. Now it backs off out of the radius after
    DOCK_RETRY_S and comes again (the base, the contact and the rule as both ROS versions run them, 0.96 s
    ticks)."""
    from battery_simulator.robot.base import Base
    from battery_simulator.robot.dock_contact import DockContact

    contact = DockContact(0.0, 0.0, 0.3, 0.05)
    assert contact.update(0.05, 0.15, 0.0, 0.0) is True   # touched on its way in
    assert contact.update(-0.01, -0.13, 0.2, 0.0) is False   # carried across: leaving, to the contact
    phases, goals = [], []
    behaviour = patrol.Patrol(patrol.DEFAULT_WAYPOINTS, 0.0, 0.0, 0.3, 0.6, phases.append, lambda: goals.append(1))
    behaviour.phase = patrol.GO_TO_DOCK
    base = Base(-0.01, -0.13, -1.5, cmd_vel_timeout=0.5)
    now, farthest = 100.0, 0.0
    base.step(now)
    while behaviour.phase == patrol.GO_TO_DOCK and now < 400.0:
        now += 0.96
        (x, y, yaw), (linear, _) = base.step(now)
        contact.update(x, y, linear, 0.0)
        farthest = max(farthest, (x * x + y * y) ** 0.5)
        base.command(*behaviour.control((x, y, yaw), True, contact.contact, 0.96), now)
    assert phases == [patrol.CHARGING] and goals == [1], 'still %s after %.0f s on the dock without the contact' % (
        behaviour.phase, now - 100.0)
    assert farthest > 0.3, 'it docked again without leaving the contact\'s radius'


def test_a_charge_goal_ended_by_a_server_shutting_down_is_information_in_words():
    assert patrol.goal_failed_line('preempted', 'Preempted at 81.2 % (server shutting down, charging)') == (
        False, 'the battery server is shutting down (Preempted at 81.2 % (server shutting down, charging)): the '
               'charge goal is sent again when it is back')
    assert patrol.goal_failed_line('aborted', 'the mode turned to discharge') == (
        True, 'charge goal ended aborted (the mode turned to discharge): sending it again')
