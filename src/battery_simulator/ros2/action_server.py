"""The ``battery_simulator`` node's role for one battery on ROS 2: the action, the services, the
inputs, the ``charging`` parameter and the live settings, around one core Battery.

Everything runs in the executor's one thread: ``update()`` is called by a
timer (wall time, ``update_rate`` Hz) and steps the battery. A goal is
accepted and followed by the updates (feedback at each); it is executed only
once its end is known (Full, Empty, preempted by a new goal, cancelled,
aborted), by a callback that sets that end and returns the result at once. So
no callback blocks and no coroutine waits: rclpy's executor re-runs a waiting
coroutine at every turn, which would spin a core while a goal runs. The goal
shows ACCEPTED while it runs. A service's change is stepped and handed to the
status front before the reply, so the next ``battery_status`` shows it.
"""
import math

from geometry_msgs.msg import Twist
from rcl_interfaces.msg import SetParametersResult
from rclpy.action import ActionServer, CancelResponse, GoalResponse
from rclpy.parameter import Parameter
from std_msgs.msg import Bool
from std_srvs.srv import SetBool, Trigger

from battery_simulator.action import BatterySim
from battery_simulator.core.battery import BatteryError, Goal, GoalEnd
from battery_simulator.core.battery_model import Mode
from battery_simulator.core.prediction import PredictionError, plan_from_arrays, predict
from battery_simulator.msg import BatterySimState
from battery_simulator.core import topics
from battery_simulator.ros2.messages import SimState
from battery_simulator.ros2.qos import LATCHED_QOS
from battery_simulator.srv import InjectFault, Predict, SetLoad, SetState

MODE_PARAMETER = 'charging'
LOG_PERIOD_S = 1.0
JUMP_LOG_PERIOD_S = 10.0   # a clock that jumps back and forth (two /clock publishers) warns this often


class _ActiveGoal:
    def __init__(self, handle, goal):
        self.handle, self.goal = handle, goal


class BatterySimServer:
    """One battery's action, services, subscriptions, ``charging`` and live parameters on ``node``."""

    def __init__(self, node, battery, namespace, log, status=None, store=None):
        """``namespace``: '' for the node's own names, 'robot3/' in a fleet host's shared node;
        ``status``: the BatteryStatePublisher fed at every update; ``store``: a saved-state keeper (maybe_save/save_now)."""
        self.node, self.battery, self._log = node, battery, log
        self._status = status
        self._store = store
        self._active = None
        self._setting_mode = False
        ns = namespace
        self._state_pub = node.create_publisher(BatterySimState, ns + topics.STATE_TOPIC, LATCHED_QOS)
        self._action = ActionServer(node, BatterySim, ns + topics.ACTION, execute_callback=self._not_followed,
                                    goal_callback=lambda goal: GoalResponse.ACCEPT,
                                    handle_accepted_callback=self._accepted,
                                    cancel_callback=lambda handle: CancelResponse.ACCEPT)
        node.create_subscription(Twist, ns + topics.CMD_VEL, self._on_cmd_vel, 1)
        node.create_subscription(Bool, ns + topics.CHARGER_CONTACT, self._on_contact, 10)
        node.create_service(SetLoad, ns + topics.SET_LOAD, self._set_load)
        node.create_service(SetBool, ns + topics.SET_CHARGING, self._set_charging)
        node.create_service(SetState, ns + topics.SET_STATE, self._set_state)
        node.create_service(Trigger, ns + topics.RESET, self._reset)
        node.create_service(InjectFault, ns + topics.INJECT_FAULT, self._inject_fault)
        node.create_service(Predict, ns + topics.PREDICT, self._predict)

    # -- parameters (the node owns them: one battery per node) ----------------------------------

    def on_set_parameters(self, parameters):
        """The node's on-set callback: ``charging`` follows the mode; live settings are checked by the
        battery (refused with its reason, the old value kept); read-only ones are refused by rclpy."""
        if self._setting_mode:
            return SetParametersResult(successful=True)
        for parameter in parameters:
            if parameter.name == MODE_PARAMETER:
                self.battery.follow_mode_value(parameter.value)
            elif parameter.name in self.battery.live_values():
                try:
                    self.battery.set_live(parameter.name, parameter.value)
                except BatteryError as error:
                    return SetParametersResult(successful=False, reason=str(error))
        self.update(publish_now=True)
        return SetParametersResult(successful=True)

    def _write_mode(self, mode):
        """Write ``charging`` to match a mode the battery took from a goal or the contact."""
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
            publishers = [info.node_name for info in self.node.get_publishers_info_by_topic('/clock')]
            self._log.warn_throttle(JUMP_LOG_PERIOD_S, '%s', update.time_jump_warning(
                self.battery.max_time_jump, publishers))
        state = SimState(update.record)
        if self._state_pub.get_subscription_count() > 0:
            self._state_pub.publish(state.message())
        if self._status is not None:
            self._status.on_state(state, publish_now)
        if self._store is not None:
            self._store.maybe_save(update.saved_state)
        self._check_goal(update.snapshot)

    def finish(self):
        """At shutdown: end the active goal and save the state."""
        if self._active is not None:
            self._end_goal(self.battery.preempted('server shutting down'))
        if self._store is not None:
            self._store.save_now(self.battery.export_state())

    # -- the action ------------------------------------------------------------------------------

    def _accepted(self, handle):
        """A new goal preempts the active one (SimpleActionServer's rule); the updates follow it."""
        if self._active is not None:
            self._end_goal(self.battery.preempted('a new goal'))
        goal = Goal(handle.request.charge_state)
        self._active = _ActiveGoal(handle, goal)
        self.battery.set_mode(goal.mode, 'goal')
        self._write_mode(goal.mode)
        snapshot = self.battery.snapshot_now()
        self._log.info_throttle(LOG_PERIOD_S, 'goal: %s from %.1f %%', goal.mode.value, snapshot.percentage)
        self.update(publish_now=True)   # a goal that starts where it would end succeeds at once

    def _end_goal(self, end):
        """End the active goal: execute it now with a callback that sets ``end`` and returns its result."""
        active, self._active = self._active, None
        active.handle.execute(lambda handle: self._conclude(handle, end))

    def _conclude(self, handle, end):
        if end.outcome == GoalEnd.SUCCEEDED:
            handle.succeed()
        elif handle.is_cancel_requested:
            handle.canceled()
        else:
            handle.abort()
        self._log.info_throttle(LOG_PERIOD_S, 'goal ended: %s', end.text)
        return BatterySim.Result(battery_status=end.text)

    def _not_followed(self, handle):
        """The ActionServer's default execute callback: never called for a goal this front follows."""
        handle.abort()
        return BatterySim.Result(battery_status='Aborted: the goal was not followed')

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
        try:
            self.battery.on_cmd_vel(twist.linear.x, twist.angular.z)
        except BatteryError as error:
            self._log.error_throttle(10.0, '%s', error)

    def _on_contact(self, msg):
        self._change_contact(bool(msg.data), 'charger contact')

    def _change_contact(self, connected, source):
        if self.battery.change_contact(connected, source):
            self._write_mode(self.battery.mode)
            self._log.info_throttle(LOG_PERIOD_S, '%s: charger %s', source,
                                    'connected' if connected else 'disconnected')
            self.update(publish_now=True)

    def _service(self, response, change):
        """Run ``change()`` (the reply's text) on the battery, publish it, then reply; a refusal replies
        success false with the battery's reason and changes nothing."""
        try:
            self.battery.advance_to_now()
            response.message = change()
            response.success = True
        except BatteryError as error:
            response.success, response.message = False, str(error)
            return response
        self.update(publish_now=True)
        return response

    def _set_charging(self, request, response):
        connected = bool(request.data)
        return self._service(response, lambda: self._change_contact(connected, 'set_charging') or
                             'charger %s' % ('connected' if connected else 'disconnected'))

    def _set_load(self, request, response):
        return self._service(response, lambda: self.battery.set_load(request.name, request.power_w))

    def _set_state(self, request, response):
        return self._service(response, lambda: self.battery.set_state(
            request.percentage, request.temperature_c, request.state_of_health, request.gauge_error))

    def _reset(self, request, response):
        return self._service(response, self.battery.reset)

    def _inject_fault(self, request, response):
        return self._service(response, lambda: self.battery.inject_fault(request.fault, request.active))

    def _predict(self, request, response):
        """What the plan would do, from a copy of the battery brought to now (changes nothing)."""
        nan = math.nan
        try:
            segments = plan_from_arrays(list(request.duration_s), list(request.current_a), list(request.power_w),
                                        list(request.speed_mps), list(request.turn_radps))
            result = predict(self.battery.model_for_prediction(), segments, request.charge_to_percentage)
        except PredictionError as error:
            response.success, response.message = False, str(error)
            response.end_percentage = response.end_voltage_v = response.min_voltage_v = nan
            response.max_temperature_c = response.cut_off_at_s = response.charge_time_s = nan
            return response
        response.success, response.message, response.feasible = True, result.summary(), result.feasible
        response.end_percentage, response.end_voltage_v = result.end_percentage, result.end_voltage_v
        response.min_voltage_v, response.max_temperature_c = result.min_voltage_v, result.max_temperature_c
        response.cut_off_at_s, response.charge_time_s = result.cut_off_at_s, result.charge_time_s
        return response
