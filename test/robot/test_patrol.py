"""patrol_and_dock's rest_on_dock (issue 43: the demo with a learning gauge rests on the dock once full, where
the gauge reads the rest): the robot stays in CHARGING for that much ROS time after the goal ended Full."""
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
