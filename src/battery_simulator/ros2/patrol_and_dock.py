"""``patrol_and_dock`` (ROS 2): the demo behaviour, as ROS 1's patrol_and_dock.py.

Patrols a loop of waypoints; when ``battery_low`` turns true drives to the dock; on ``charger_contact``
sends a charge goal to the ``battery_simulator`` action and waits for it to end "Full"; backs off the dock
and patrols again (robot/patrol.py). Each phase change is logged with the level ("phase GO_TO_DOCK at
25.1 %") and published on ``patrol_and_dock/phase`` (std_msgs/msg/String, transient local). It steers only
on odometry newer than its last command, at 20 Hz of ROS time.

:Subscribes: ``odom``, ``battery_low``, ``charger_contact``, ``battery_status`` (for the level in the log)
:Publishes: ``cmd_vel`` (geometry_msgs/msg/Twist), ``patrol_and_dock/phase``
:Parameters: ``waypoints`` (flat list x1, y1, x2, y2 ... m), ``dock_x``, ``dock_y`` (m), ``speed`` (m/s, 0.3),
  ``undock_distance`` (m, 0.6), ``rest_on_dock`` (s of ROS time on the dock once full, 0)
"""
import math
import time

from action_msgs.msg import GoalStatus
from geometry_msgs.msg import Twist
from nav_msgs.msg import Odometry
from rclpy.action import ActionClient
from sensor_msgs.msg import BatteryState
from std_msgs.msg import Bool, String

from battery_simulator.action import BatterySim
from battery_simulator.core import ros_names
from battery_simulator.robot import patrol as rule
from battery_simulator.ros2.qos import LATCHED_QOS, STATUS_QOS
from battery_simulator.ros2.startup import run_node, steady_clock

STARTUP_WAIT_S = 30.0   # wall seconds to wait for the battery's action server and its first battery_status
STARTUP_CHECK_S = 0.1
PHASE_TOPIC = ros_names.PHASE
GOAL_STATE_NAMES = {GoalStatus.STATUS_ABORTED: 'aborted', GoalStatus.STATUS_CANCELED: 'canceled',
                    GoalStatus.STATUS_UNKNOWN: 'unknown'}
ROS2_DEFAULTS = {'waypoints': rule.DEFAULT_WAYPOINTS_FLAT}


class PatrolAndDock:
    def __init__(self, node, waypoints, dock_x, dock_y, speed, undock_distance, rest_on_dock=0.0):
        self._node = node
        self._pose = None
        self._pose_stamp_s = -math.inf     # ROS time of the pose
        self._commanded_at_s = -math.inf   # ROS time of the last command sent
        self._low = self._contact = False
        self._percentage = float('nan')
        self._status_seen = False
        self._goal_outcome = None
        self._last_s = None
        self._due_step_s = None   # a control step waiting for a fresh pose
        self._patrol = rule.Patrol(waypoints, dock_x, dock_y, speed, undock_distance, self._enter, self._send_goal,
                                   rest_on_dock)
        self._client = ActionClient(node, BatterySim, ros_names.ACTION)
        self._cmd_pub = node.create_publisher(Twist, ros_names.CMD_VEL, 1)
        self._phase_pub = node.create_publisher(String, PHASE_TOPIC, LATCHED_QOS)
        self._subs = [
            node.create_subscription(Odometry, ros_names.ODOM, self._on_odom, 1),
            node.create_subscription(Bool, ros_names.BATTERY_LOW, self._on_low, LATCHED_QOS),
            node.create_subscription(Bool, ros_names.CHARGER_CONTACT, self._on_contact, LATCHED_QOS),
            node.create_subscription(BatteryState, ros_names.BATTERY_STATUS, self._on_battery, STATUS_QOS),
        ]
        self._started_at = time.monotonic()
        self._startup = node.create_timer(STARTUP_CHECK_S, self._wait_for_battery, clock=steady_clock())
        self._control_timer = None

    def _wait_for_battery(self):
        """Start patrolling once the action server is up and battery_status came (or 30 s wall passed)."""
        waited_s = time.monotonic() - self._started_at
        if not self._client.server_is_ready():
            if waited_s > STARTUP_WAIT_S:
                self._node.get_logger().fatal('no action server %s after %g s' % (
                    self._node.resolve_topic_name(ros_names.ACTION), STARTUP_WAIT_S))
                self._node.destroy_timer(self._startup)
                self._node.context.try_shutdown()   # the process ends, as ROS 1's node does
            return
        if not self._status_seen and waited_s <= STARTUP_WAIT_S:
            return
        if not self._status_seen:
            self._node.get_logger().warning('no %s after %g s: patrolling without the level' % (
                self._node.resolve_topic_name(ros_names.BATTERY_STATUS), STARTUP_WAIT_S))
        self._node.destroy_timer(self._startup)
        self._patrol.start()
        self._control_timer = self._node.create_timer(1.0 / rule.CONTROL_RATE_HZ, self._on_tick)   # ROS time

    def _now_s(self):
        return self._node.get_clock().now().nanoseconds * 1e-9

    def _on_odom(self, odom):
        pose = odom.pose.pose
        self._pose = (pose.position.x, pose.position.y, rule.yaw_of(pose.orientation.z, pose.orientation.w))
        self._pose_stamp_s = odom.header.stamp.sec + odom.header.stamp.nanosec * 1e-9
        if self._due_step_s is not None:   # a step waited for this pose
            self._control(self._due_step_s)

    def _on_low(self, msg):
        self._low = msg.data

    def _on_contact(self, msg):
        self._contact = msg.data

    def _on_battery(self, msg):
        self._percentage = 100.0 * msg.percentage
        self._status_seen = True

    def _on_tick(self):
        now = self._now_s()
        step_s = rule.control_step(self._last_s if self._last_s is not None else now, now)
        if self._last_s is None:
            step_s = 1.0 / rule.CONTROL_RATE_HZ
        if step_s is None:   # ROS time has not moved
            return
        self._last_s = now
        self._due_step_s = step_s
        self._control(step_s)

    def _control(self, step_s):
        """One step on a pose newer than the last command (a pose the last command has not moved would be
        steered again: late odometry turns the robot in circles); without one, the step waits for it."""
        if self._pose is None or self._pose_stamp_s <= self._commanded_at_s:
            return
        self._due_step_s = None
        outcome, self._goal_outcome = self._goal_outcome, None
        linear, angular = self._patrol.control(self._pose, self._low, self._contact, step_s, outcome)
        twist = Twist()
        twist.linear.x, twist.angular.z = linear, angular
        self._cmd_pub.publish(twist)
        self._commanded_at_s = self._last_s

    def _enter(self, phase):
        self._node.get_logger().info('phase %s at %.1f %%' % (phase, self._percentage))
        self._phase_pub.publish(String(data=phase))

    def _send_goal(self):
        self._goal_outcome = None
        self._client.send_goal_async(BatterySim.Goal(charge_state=True)).add_done_callback(self._on_goal_response)

    def _on_goal_response(self, future):
        handle = future.result()
        if handle is None or not handle.accepted:
            self._goal_ended(GoalStatus.STATUS_UNKNOWN, 'rejected')
            return
        handle.get_result_async().add_done_callback(
            lambda result: self._goal_ended(result.result().status, result.result().result.battery_status))

    def _goal_ended(self, status, text):
        if status == GoalStatus.STATUS_SUCCEEDED:
            self._goal_outcome = rule.GOAL_SUCCEEDED
            return
        warning, line = rule.goal_failed_line(GOAL_STATE_NAMES.get(status, str(status)), text)
        (self._node.get_logger().warning if warning else self._node.get_logger().info)(line)
        self._goal_outcome = rule.GOAL_FAILED


def main(args=None):
    run_node('patrol_and_dock', rule.SETTINGS, PatrolAndDock, args, ROS2_DEFAULTS)
