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


class GoalArrivingDuringSetUp:
    """A SimpleActionServer with one goal waiting; a second goal comes while the worker sets the first one up
    (its mode, parameter and log line: a master call and more on a busy machine)."""

    def __init__(self):
        self.new_goal = True
        self.preempt_request = False

    def is_new_goal_available(self):
        return self.new_goal

    def is_preempt_requested(self):
        return self.preempt_request

    def accept_new_goal(self):
        self.new_goal = self.preempt_request = False
        return type('Goal', (), {'charge_state': True})()

    def second_goal_arrives(self):   # internal_goal_callback: new_goal first, then the active goal's preempt
        self.new_goal = True
        self.preempt_request = True


def test_a_goal_arriving_while_the_first_is_set_up_preempts_it_as_a_new_goal():
    """Two CPU hogs: 'Preempted at 88.4 % (cancel, charging)' for a goal a newer one replaced (rostest
    action_interface and its fleet twin in one fresh-clone run)."""
    server = BatterySimServer.__new__(BatterySimServer)
    fake = GoalArrivingDuringSetUp()
    server._server = fake
    server._goal = None
    server._set_mode = lambda mode, source: fake.second_goal_arrives()
    server.battery = type('Battery', (), {'snapshot_now': lambda self: type('S', (), {'percentage': 88.4})()})()
    server._lines = type('Lines', (), {'goal_started': lambda self, mode, percentage: None})()
    reasons, checked = [], []

    def preempt(reason):   # as BatterySimServer._preempt: only an active goal ends
        if server._goal is not None:
            reasons.append(reason)
            server._goal = None
    server._preempt = preempt
    server._check_goal = checked.append
    server._take_goals()
    assert reasons == [] and len(checked) == 1, (reasons, checked)   # the first goal runs on this turn
    server._take_goals()
    assert reasons == ['a new goal'], reasons
