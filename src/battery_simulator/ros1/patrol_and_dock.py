"""The demo behaviour (patrol_and_dock): patrol, dock when low, charge, undock, patrol again.

It patrols a loop of waypoints. When ``battery_low`` turns true it drives to
the dock and stops on it; on charger contact it sends a charge goal to the
``battery_simulator`` action (the textbook interface) and waits for "Full";
then it backs off the dock and patrols again. Each phase change is logged with
the battery level and published on ``patrol_and_dock/phase``. The phases and
the driving are robot/patrol.py's; this node gives them ROS's inputs.

:ROS Parameters:
  - ``~waypoints`` (list of [x, y], m): the patrol loop (default a 2 m square beside the dock)
  - ``~dock_x``, ``~dock_y`` (float, m): the dock (default 0, 0), as battery_dock_contact has it
  - ``~speed`` (float, m/s > 0): cruising speed (default 0.3)
  - ``~undock_distance`` (float, m > 0): how far to back off the dock (default 0.6)
  - ``~rest_on_dock`` (float, s >= 0): how long to stay on the dock once full, ROS time (default 0)

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
from battery_simulator.core import ros_names
from battery_simulator.robot import patrol as rule
from battery_simulator.ros1.startup import init_node, read_private_settings

STARTUP_WAIT_S = 30.0     # wall seconds to wait for the battery's action server
FRESH_POSE_WAIT_S = 0.1   # wall seconds to wait for odometry newer than the last command
GOAL_FAILED_STATES = (GoalStatus.ABORTED, GoalStatus.PREEMPTED, GoalStatus.REJECTED, GoalStatus.LOST)
GOAL_STATE_NAMES = {GoalStatus.ABORTED: 'aborted', GoalStatus.PREEMPTED: 'preempted', GoalStatus.REJECTED: 'rejected',
                    GoalStatus.LOST: 'lost'}


def read_settings():
    return read_private_settings(rule.SETTINGS)


class PatrolAndDock:
    def __init__(self, waypoints, dock_x, dock_y, speed, undock_distance, rest_on_dock=0.0):
        self._lock = threading.Lock()   # guards the inputs below
        self._pose_arrived = threading.Condition(self._lock)
        self._pose = None
        self._pose_stamp_s = -math.inf   # ROS time of the pose
        self._commanded_at_s = -math.inf   # ROS time of the last command sent
        self._low = False
        self._contact = False
        self._percentage = float('nan')
        self._patrol = rule.Patrol(waypoints, dock_x, dock_y, speed, undock_distance, self._enter, self._send_goal,
                                   rest_on_dock)
        self._client = actionlib.SimpleActionClient(ros_names.ACTION, battery_simAction)
        self._cmd_pub = rospy.Publisher(ros_names.CMD_VEL, Twist, queue_size=1)
        self._phase_pub = rospy.Publisher(ros_names.PHASE, String, queue_size=1, latch=True)
        self._subs = [
            rospy.Subscriber(ros_names.ODOM, Odometry, self._on_odom, queue_size=1),
            rospy.Subscriber(ros_names.BATTERY_LOW, Bool, self._on_low, queue_size=1),
            rospy.Subscriber(ros_names.CHARGER_CONTACT, Bool, self._on_contact, queue_size=1),
            rospy.Subscriber(ros_names.BATTERY_STATUS, BatteryState, self._on_battery, queue_size=1),
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
        with self._lock:
            self._pose = (pose.position.x, pose.position.y, rule.yaw_of(pose.orientation.z, pose.orientation.w))
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
        with self._lock:
            percentage = self._percentage
        rospy.loginfo('phase %s at %.1f %%', phase, percentage)
        self._phase_pub.publish(String(data=phase))

    def _send_goal(self):
        self._client.send_goal(battery_simGoal(charge_state=True))

    def spin(self):
        if not self._wait_for_server(STARTUP_WAIT_S):
            rospy.logfatal('no action server %s after %g s', rospy.resolve_name(ros_names.ACTION), STARTUP_WAIT_S)
            return
        try:
            rospy.wait_for_message(ros_names.BATTERY_STATUS, BatteryState, timeout=30.0)
        except rospy.ROSException:
            rospy.logwarn('no %s after 30 s: patrolling without the level', rospy.resolve_name(ros_names.BATTERY_STATUS))
        self._patrol.start()
        rate = rospy.Rate(rule.CONTROL_RATE_HZ, reset=True)   # ROS time; reset: a /clock jump back restarts it
        last = rospy.get_time()
        while not rospy.is_shutdown():
            now = rospy.get_time()
            step_s = rule.control_step(last, now)
            if step_s is not None:   # ROS time moved (a coarse clock: rospy.Rate may wake twice a tick)
                last = now
                pose, low, contact = self._fresh_inputs()
                if pose is not None:
                    self._cmd_pub.publish(self._twist(*self._patrol.control(
                        pose, low, contact, step_s, self._goal_outcome())))
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

    def _goal_outcome(self):
        """How the charge goal ended (robot/patrol.py's GOAL_*), or None while it runs (or outside CHARGING)."""
        if self._patrol.phase != rule.CHARGING:
            return None
        state = self._client.get_state()
        if state == GoalStatus.SUCCEEDED:
            return rule.GOAL_SUCCEEDED
        if state in GOAL_FAILED_STATES:
            warning, line = rule.goal_failed_line(GOAL_STATE_NAMES.get(state, str(state)),
                                                  self._client.get_goal_status_text())
            (rospy.logwarn if warning else rospy.loginfo)(line)
            return rule.GOAL_FAILED
        return None

    @staticmethod
    def _twist(linear, angular):
        twist = Twist()
        twist.linear.x, twist.angular.z = linear, angular
        return twist


def main():
    PatrolAndDock(**init_node('patrol_and_dock', read_settings)).spin()
