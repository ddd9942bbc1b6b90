"""ROS 1's action server: a goal that arrives while the worker reads actionlib's flags is a new goal,
never a cancel (the rostest action_interface_fleet failed so under load: 'Preempted at 88.1 % (cancel)')."""
from battery_simulator.ros1.action_server import BatterySimServer


class GoalArrivingBetweenReads:
    """actionlib's SimpleActionServer whose goal callback runs right after the worker's first flag read:
    as internal_goal_callback does, it sets new_goal first, then preempt_request (the active goal)."""

    def __init__(self):
        self.new_goal = False
        self.preempt_request = False
        self.reads = 0

    def _read(self, value_of):
        value = value_of()
        self.reads += 1
        if self.reads == 1:
            self.new_goal = True
            self.preempt_request = True
        return value

    def is_new_goal_available(self):
        return self._read(lambda: self.new_goal)

    def is_preempt_requested(self):
        return self._read(lambda: self.preempt_request)

    def accept_new_goal(self):
        return None


def test_a_goal_arriving_between_the_flag_reads_preempts_as_a_new_goal():
    server = BatterySimServer.__new__(BatterySimServer)
    server._server = GoalArrivingBetweenReads()
    server._goal = object()
    reasons = []
    server._preempt = reasons.append
    server._take_goals()
    assert reasons == ['a new goal'], reasons


def test_a_cancel_alone_is_a_cancel():
    server = BatterySimServer.__new__(BatterySimServer)
    fake = GoalArrivingBetweenReads()
    fake.reads = 1          # nothing arrives
    fake.preempt_request = True
    server._server = fake
    server._goal = object()
    reasons = []
    server._preempt = reasons.append
    server._take_goals()
    assert reasons == ['cancel'], reasons
