"""The ``battery_simulator`` node's role for one battery on ROS 2: the action, the inputs, the ``charging``
parameter and the live settings, around one core Battery (its services: services.py).

Everything runs in the executor's one thread: ``update()`` is called by a
timer (wall time, ``update_rate`` Hz) and steps the battery. An accepted goal
is executed at once (EXECUTING while it runs, as ROS 2 action clients and
tools expect): its execute callback is a coroutine that awaits the goal's end
(Full, Empty, preempted by a new goal, cancelled, aborted, or the server
shutting down), which the updates decide; rclpy resumes a waiting coroutine
once per executor turn, so nothing spins and no thread is held per goal.
``charging`` takes true / false and 1 / 0 (ROS 1's values); a parameter set
is checked whole before any of it acts (a refused set changes nothing).
"""
from rcl_interfaces.msg import SetParametersResult
from rclpy.action import ActionServer, CancelResponse, GoalResponse
from rclpy.parameter import Parameter
from rclpy.task import Future
from std_msgs.msg import Bool

from battery_simulator.action import BatterySim
from battery_simulator.core import ros_names
from battery_simulator.core.battery import BatteryError, Goal, GoalEnd
from battery_simulator.core.battery_states import Mode
from battery_simulator.core.node_settings import SettingError, check_setting, setting
from battery_simulator.core.server_log import SHUTDOWN_TEXT, ServerLog
from battery_simulator.msg import BatterySimState
from battery_simulator.ros2.messages import SimState
from battery_simulator.ros2.qos import LATCHED_QOS
from battery_simulator.ros2.services import BatteryServices
from battery_simulator.ros2.velocity import VelocityInput

MODE_PARAMETER = ros_names.CHARGING_PARAM


class _ActiveGoal:
    def __init__(self, handle, goal):
        self.handle, self.goal = handle, goal
        self.ended = Future()   # its GoalEnd, once the updates (or a new goal, a cancel, shutdown) decide it


class BatterySimServer:
    """One battery's action, services, subscriptions, ``charging`` and live parameters on ``node``."""

    def __init__(self, node, battery, namespace, log, status=None, store=None, mode_parameter=True, graph_types=None):
        """``namespace``: '' for the node's own names, 'robot3/' in a fleet host's shared node;
        ``status``: the BatteryStatePublisher fed at every update; ``store``: a saved-state keeper (maybe_save/save_now);
        ``mode_parameter``: the node's ``charging`` follows the mode (False on a shared node, whose parameters
        are the host's); ``graph_types``: a GraphTypes shared by the fronts of one node (velocity.py)."""
        self.node, self.battery, self._log = node, battery, log
        self._lines = ServerLog(log)
        self._mode_parameter = mode_parameter
        self._status = status
        self._store = store
        self._active = None
        self._goals = {}           # goal id -> its _ActiveGoal, until its execute callback takes it
        self._running = 0          # execute callbacks not yet returned (their results not yet sent)
        self._setting_mode = False
        self._finishing = False   # after finish(): the server is shutting down, new goals are rejected
        ns = namespace
        self._state_pub = node.create_publisher(BatterySimState, ns + ros_names.STATE_TOPIC, LATCHED_QOS)
        self._action = ActionServer(node, BatterySim, ns + ros_names.ACTION, execute_callback=self._execute,
                                    goal_callback=self._goal_response,
                                    handle_accepted_callback=self._accepted,
                                    cancel_callback=lambda handle: CancelResponse.ACCEPT)
        self._cmd_vel_name = ns + ros_names.CMD_VEL
        self._cmd_vel = VelocityInput(node, ns + ros_names.CMD_VEL, self._on_cmd_vel,   # Twist or TwistStamped
                                      graph_types=graph_types)
        node.create_subscription(Bool, ns + ros_names.CHARGER_CONTACT, self._on_contact, 10)
        self.services = BatteryServices(node, ns, self)

    # -- parameters (the node owns them: one battery per node) ----------------------------------

    def on_set_parameters(self, parameters):
        """The node's on-set callback: the whole set is checked before any of it acts (a refusal, with its
        reason, changes nothing); ``charging`` follows the mode; live settings are the battery's."""
        if self._setting_mode:
            return SetParametersResult(successful=True)
        modes = [p.value for p in parameters if p.name == MODE_PARAMETER]
        for value in modes:
            reason = mode_refusal(value)
            if reason is not None:
                return SetParametersResult(successful=False, reason=reason)
        live = [(p.name, p.value) for p in parameters if p.name in self.battery.live_values()]
        reason = self._set_live_all(live)
        if reason is not None:
            return SetParametersResult(successful=False, reason=reason)
        for value in modes:
            self.battery.follow_mode_value(value)
        self.update(publish_now=True)
        return SetParametersResult(successful=True)

    def _set_live_all(self, changes):
        """Apply every live change, or none (the ones applied are put back): None, or the refusal."""
        before = self.battery.live_values()
        done = []
        try:
            for name, value in changes:
                self.battery.set_live(name, value)
                done.append(name)
        except BatteryError as error:
            for name in reversed(done):
                self.battery.set_live(name, before[name])
            return str(error)
        return None

    def _write_mode(self, mode):
        """Write ``charging`` to match a mode the battery took from a goal or the contact."""
        if not self._mode_parameter:
            return
        self._setting_mode = True
        try:
            self.node.set_parameters([Parameter(MODE_PARAMETER, Parameter.Type.BOOL, mode is Mode.CHARGE)])
        finally:
            self._setting_mode = False

    # -- updates ---------------------------------------------------------------------------------

    def update(self, publish_now=False):
        """Step the battery to now, publish its state, feed and end the active goal."""
        update = self.battery.update()
        if update.time_jump is not None:
            publishers = [info.node_name for info in self.node.get_publishers_info_by_topic(ros_names.CLOCK)]
            self._lines.time_jump(update, self.battery.max_time_jump, publishers)
        state = SimState(update.record)
        if self._state_pub.get_subscription_count() > 0:
            self._state_pub.publish(state.message())
        if self._status is not None:
            self._status.on_state(state, publish_now)
        if self._store is not None:
            self._store.maybe_save(update.saved_state)
        self._lines.progress(update.snapshot)
        self._check_goal(update.snapshot)
        self._lines.settle()
        taken = self._cmd_vel.follow_publishers()
        if taken is not None:
            self._log.info('%s: taking %s, as its publishers send', self.node.resolve_topic_name(
                self._cmd_vel_name), taken)

    def finish(self):
        """At shutdown, while the context is up: end the active goal (aborted, "server shutting down") and
        save the state. Returns a function telling whether the goal's result has been sent."""
        self._finishing = True
        if self._active is not None:
            self._end_goal(self.battery.preempted(SHUTDOWN_TEXT))
        if self._store is not None:
            self._store.save_now(self.battery.export_state())
        return lambda: self._running == 0

    # -- the action ------------------------------------------------------------------------------

    def _goal_response(self, goal):
        """Every goal is accepted, but once the server is shutting down (its state saved, its last results on
        their way): one accepted then would never run."""
        if self._finishing:
            self._lines.goal_rejected(SHUTDOWN_TEXT)
            return GoalResponse.REJECT
        return GoalResponse.ACCEPT

    def _accepted(self, handle):
        """A new goal preempts the active one (SimpleActionServer's rule) and executes at once; the updates
        follow it."""
        if self._active is not None:
            self._end_goal(self.battery.preempted('a new goal'))
        goal = Goal(handle.request.charge_state)
        self._active = _ActiveGoal(handle, goal)
        self._goals[bytes(handle.goal_id.uuid)] = self._active
        self._running += 1
        handle.execute()
        self.battery.set_mode(goal.mode, 'goal')
        self._write_mode(goal.mode)
        snapshot = self.battery.snapshot_now()
        self._lines.goal_started(goal.mode, snapshot.percentage)
        self.update(publish_now=True)   # a goal that starts where it would end succeeds at once

    async def _execute(self, handle):
        """The goal's execute callback: waits (a coroutine, no thread) for its end, then concludes it."""
        try:
            active = self._goals.pop(bytes(handle.goal_id.uuid))
            end = await active.ended
            return self._conclude(handle, end)
        finally:
            self._running -= 1

    def _end_goal(self, end):
        """End the active goal: its execute callback concludes it with ``end``."""
        active, self._active = self._active, None
        active.ended.set_result(end)

    def _conclude(self, handle, end):
        if end.outcome == GoalEnd.SUCCEEDED:
            handle.succeed()
        elif handle.is_cancel_requested:
            handle.canceled()
        else:
            handle.abort()
        self._lines.goal_ended(end)
        return BatterySim.Result(battery_status=end.text)

    def _check_goal(self, snapshot):
        active = self._active
        if active is None:
            return
        if active.handle.is_cancel_requested:
            self._end_goal(self.battery.preempted('cancel'))
            return
        active.handle.publish_feedback(BatterySim.Feedback(battery_percentage=snapshot.percentage))
        end = self.battery.goal_end(active.goal, snapshot)
        if end is not None:
            self._end_goal(end)

    # -- inputs ----------------------------------------------------------------------------------

    def _on_cmd_vel(self, twist):
        self.battery.take_cmd_vel(twist)

    def _on_contact(self, msg):
        self.change_contact(bool(msg.data), 'charger contact')

    def change_contact(self, connected, source):
        if self.battery.change_contact(connected, source):
            self._write_mode(self.battery.mode)
            self._lines.charger(connected, source)
            self.update(publish_now=True)


def mode_refusal(value, shown_name=MODE_PARAMETER):
    """Why a ``charging`` value is refused (core/node_settings.py's one line naming it), or None."""
    try:
        check_setting(setting('charging'), value, shown_name)
    except SettingError as error:
        return str(error)
    return None
