"""The demo behaviour (patrol_and_dock): patrol, dock when low, charge, undock, patrol again.

It patrols a loop of waypoints. When ``battery_low`` turns true it drives to
the dock and stops on it; on charger contact it sends a charge goal to the
``battery_simulator`` action (the textbook interface) and waits for "Full";
then it backs off the dock and patrols again. Each phase change is logged with
the battery level and published on ``patrol_and_dock/phase``.

:ROS Parameters:
  - ``~waypoints`` (list of [x, y], m): the patrol loop (default a 2 m square beside the dock)
  - ``~dock_x``, ``~dock_y`` (float, m): the dock (default 0, 0), as battery_dock_contact has it
  - ``~speed`` (float, m/s > 0): cruising speed (default 0.3)
  - ``~undock_distance`` (float, m > 0): how far to back off the dock (default 0.6)

:Subscribes:
  - ``odom`` (nav_msgs/Odometry), ``battery_low`` and ``charger_contact`` (std_msgs/Bool),
    ``battery_status`` (sensor_msgs/BatteryState, for the level in the log)
:Publishes:
  - ``cmd_vel`` (geometry_msgs/Twist), ``patrol_and_dock/phase`` (std_msgs/String, latched)
:Action client:
  - ``battery_simulator`` (battery_simulator/battery_simAction)
"""
import math
import threading
import time

import actionlib
import rospy
from actionlib_msgs.msg import GoalStatus
from geometry_msgs.msg import Twist
from nav_msgs.msg import Odometry
from sensor_msgs.msg import BatteryState
from std_msgs.msg import Bool, String

from battery_simulator.msg import battery_simAction, battery_simGoal
from battery_simulator.core import topics
from battery_simulator.ros1.startup import checked_param, init_node, is_number

PATROL, GO_TO_DOCK, CHARGING, UNDOCK = 'PATROL', 'GO_TO_DOCK', 'CHARGING', 'UNDOCK'
CONTROL_RATE_HZ = 20.0
STARTUP_WAIT_S = 30.0     # wall seconds to wait for the battery's action server
ARRIVED_M = 0.08          # a waypoint counts as reached within this distance (or half a step's drive)
DOCKED_M = 0.15           # stop this close to the dock: well inside battery_dock_contact's radius (0.3 m)
MAX_TURN_RADPS = 1.5
FRESH_POSE_WAIT_S = 0.1   # wall seconds to wait for odometry newer than the last command
DEFAULT_WAYPOINTS = [[1.0, 0.0], [2.0, 0.0], [2.0, 2.0], [0.0, 2.0], [0.0, 0.8]]


def _waypoints(value):
    return (isinstance(value, list) and len(value) >= 1
            and all(isinstance(p, list) and len(p) == 2 and all(is_number(c) for c in p) for p in value))


def read_settings():
    return dict(
        waypoints=checked_param('~waypoints', DEFAULT_WAYPOINTS, _waypoints, 'a list of [x, y] points (m)'),
        dock_x=checked_param('~dock_x', 0.0, is_number, 'a number (m)'),
        dock_y=checked_param('~dock_y', 0.0, is_number, 'a number (m)'),
        speed=checked_param('~speed', 0.3, lambda v: is_number(v) and v > 0, 'a number > 0 m/s'),
        undock_distance=checked_param('~undock_distance', 0.6, lambda v: is_number(v) and v > 0, 'a number > 0 m'),
    )


def drive_to(x, y, yaw, goal_x, goal_y, speed, step_s=1.0 / CONTROL_RATE_HZ):
    """(linear, angular) to drive a unicycle at (x, y, yaw) to the goal: turn first, then go, slowing near it.

    ``step_s`` is the ROS time a command holds before the next (0.24 s under sim_clock at speed 240): no
    command drives or turns more than half the way left within one step, so it never overshoots, even
    acting on a pose one step old (the base and this node take turns on each tick).
    """
    distance = math.hypot(goal_x - x, goal_y - y)
    heading_error = math.atan2(goal_y - y, goal_x - x) - yaw
    heading_error = math.atan2(math.sin(heading_error), math.cos(heading_error))
    turn_limit = min(MAX_TURN_RADPS, 0.5 * abs(heading_error) / step_s)
    angular = max(-turn_limit, min(turn_limit, 2.5 * heading_error))
    linear = 0.0 if abs(heading_error) > 0.5 else \
        min(speed, 1.2 * distance, 0.5 * distance / step_s) * math.cos(heading_error)
    return linear, angular


class PatrolAndDock:
    def __init__(self, waypoints, dock_x, dock_y, speed, undock_distance):
        self._waypoints = [tuple(p) for p in waypoints]
        self._dock = (dock_x, dock_y)
        self._speed = speed
        self._undock_distance = undock_distance
        self._lock = threading.Lock()   # guards the inputs below
        self._pose_arrived = threading.Condition(self._lock)
        self._pose = None
        self._pose_stamp_s = -math.inf   # ROS time of the pose
        self._commanded_at_s = -math.inf   # ROS time of the last command sent
        self._low = False
        self._contact = False
        self._percentage = float('nan')
        self._phase = None
        self._next_waypoint = 0
        self._undock_from = None
        self._step_s = 1.0 / CONTROL_RATE_HZ   # the ROS time between control steps, as last seen
        self._client = actionlib.SimpleActionClient(topics.ACTION, battery_simAction)
        self._cmd_pub = rospy.Publisher(topics.CMD_VEL, Twist, queue_size=1)
        self._phase_pub = rospy.Publisher('patrol_and_dock/phase', String, queue_size=1, latch=True)
        self._subs = [
            rospy.Subscriber(topics.ODOM, Odometry, self._on_odom, queue_size=1),
            rospy.Subscriber(topics.BATTERY_LOW, Bool, self._on_low, queue_size=1),
            rospy.Subscriber(topics.CHARGER_CONTACT, Bool, self._on_contact, queue_size=1),
            rospy.Subscriber(topics.BATTERY_STATUS, BatteryState, self._on_battery, queue_size=1),
        ]

    def _wait_for_server(self, timeout_s):
        """Wait for the action server in wall time: 30 s of ROS time pass in 60 ms at sim_clock speed 480."""
        deadline = time.monotonic() + timeout_s
        while not rospy.is_shutdown() and time.monotonic() < deadline:
            if self._client.wait_for_server(rospy.Duration(0.001)):   # one look (actionlib's timeout is ROS time)
                return True
            time.sleep(0.05)
        return False

    def _on_odom(self, odom):
        pose = odom.pose.pose
        yaw = 2.0 * math.atan2(pose.orientation.z, pose.orientation.w)
        with self._lock:
            self._pose = (pose.position.x, pose.position.y, yaw)
            self._pose_stamp_s = odom.header.stamp.to_sec()
            self._pose_arrived.notify_all()

    def _on_low(self, msg):
        with self._lock:
            self._low = msg.data

    def _on_contact(self, msg):
        with self._lock:
            self._contact = msg.data

    def _on_battery(self, msg):
        with self._lock:
            self._percentage = 100.0 * msg.percentage

    def _enter(self, phase):
        self._phase = phase
        with self._lock:
            percentage = self._percentage
        rospy.loginfo('phase %s at %.1f %%', phase, percentage)
        self._phase_pub.publish(String(data=phase))

    def spin(self):
        if not self._wait_for_server(STARTUP_WAIT_S):
            rospy.logfatal('no action server %s after %g s', rospy.resolve_name(topics.ACTION), STARTUP_WAIT_S)
            return
        try:
            rospy.wait_for_message(topics.BATTERY_STATUS, BatteryState, timeout=30.0)
        except rospy.ROSException:
            rospy.logwarn('no %s after 30 s: patrolling without the level', rospy.resolve_name(topics.BATTERY_STATUS))
        self._enter(PATROL)
        rate = rospy.Rate(CONTROL_RATE_HZ, reset=True)   # ROS time; reset: a /clock jump back restarts it
        last = rospy.get_time()
        while not rospy.is_shutdown():
            now = rospy.get_time()
            if now > last or now < last - 1.0:   # ROS time moved (a coarse clock: rospy.Rate may wake twice a tick)
                self._step_s = max(1.0 / CONTROL_RATE_HZ, now - last) if now > last else 1.0 / CONTROL_RATE_HZ
                last = now
                pose, low, contact = self._fresh_inputs()
                if pose is not None:
                    self._cmd_pub.publish(self._control(pose, low, contact))
                    self._commanded_at_s = now
            try:
                rate.sleep()
            except rospy.ROSInterruptException:
                break

    def _fresh_inputs(self):
        """(pose, low, contact), the pose None unless it is newer than the last command.

        A pose that the last command has not yet moved would be steered again: on a
        starved machine odometry queues up seconds late and the robot turns in circles.
        Without a fresh pose no command is sent, and the base stops at its cmd_vel timeout.
        """
        with self._lock:
            self._pose_arrived.wait_for(lambda: self._pose_stamp_s > self._commanded_at_s, FRESH_POSE_WAIT_S)
            fresh = self._pose_stamp_s > self._commanded_at_s
            return (self._pose if fresh else None), self._low, self._contact

    def _control(self, pose, low, contact):
        """One control step of the phase machine; the Twist to send."""
        x, y, yaw = pose
        if self._phase == PATROL:
            if low:
                self._enter(GO_TO_DOCK)
                return Twist()
            goal = self._waypoints[self._next_waypoint]
            if math.hypot(goal[0] - x, goal[1] - y) < max(ARRIVED_M, 0.5 * self._speed * self._step_s):
                self._next_waypoint = (self._next_waypoint + 1) % len(self._waypoints)
            return self._twist(*drive_to(x, y, yaw, goal[0], goal[1], self._speed, self._step_s))
        if self._phase == GO_TO_DOCK:
            if contact:
                self._client.send_goal(battery_simGoal(charge_state=True))
                self._enter(CHARGING)
                return Twist()
            if math.hypot(self._dock[0] - x, self._dock[1] - y) < DOCKED_M:
                return Twist()   # on the dock: stand still until the contact closes
            return self._twist(*drive_to(x, y, yaw, self._dock[0], self._dock[1], self._speed, self._step_s))
        if self._phase == CHARGING:
            state = self._client.get_state()
            if state == GoalStatus.SUCCEEDED:
                self._undock_from = (x, y)
                self._enter(UNDOCK)
            elif state in (GoalStatus.ABORTED, GoalStatus.PREEMPTED, GoalStatus.REJECTED, GoalStatus.LOST):
                rospy.logwarn('charge goal ended in state %d (%s): sending it again',
                              state, self._client.get_goal_status_text())
                self._client.send_goal(battery_simGoal(charge_state=True))
            return Twist()
        # UNDOCK: back straight off the dock, then patrol from the first waypoint (within ARRIVED_M of
        # the distance: halving what is left each step would otherwise never get there)
        left_m = self._undock_distance - math.hypot(x - self._undock_from[0], y - self._undock_from[1])
        if left_m < ARRIVED_M:
            self._next_waypoint = 0
            self._enter(PATROL)
            return Twist()
        return self._twist(-min(0.5 * self._speed, 0.5 * left_m / self._step_s), 0.0)

    @staticmethod
    def _twist(linear, angular):
        twist = Twist()
        twist.linear.x, twist.angular.z = linear, angular
        return twist


def main():
    PatrolAndDock(**init_node('patrol_and_dock', read_settings)).spin()
