"""A kinematic differential-drive base for the demo (fake_base): no physics simulator needed.

It integrates the latest ``cmd_vel`` (held for ``~cmd_vel_timeout`` s, then
zero) into a pose, and publishes it as ``odom`` and as the tf odom ->
base_footprint, at ``~rate`` Hz. Everything runs on ROS time: under
``/use_sim_time`` with a coarse clock (0.24 s a tick at sim_clock speed 240) it
integrates over the ROS time that actually passed, exactly for a held Twist
(the rule: robot/base.py). It takes geometry_msgs/Twist or TwistStamped on ``cmd_vel``.

:ROS Parameters:
  - ``~rate`` (float, Hz, 0 < r <= 1000): integration and publication rate (default 20)
  - ``~x``, ``~y``, ``~yaw`` (float, m, m, rad): the start pose (default 0, 0, 0)
  - ``~cmd_vel_timeout`` (float, s > 0): a command older than this counts as stop (default 0.5)
  - ``~odom_frame``, ``~base_frame`` (str): frame ids (default odom, base_footprint)

:Subscribes:
  - ``cmd_vel`` (geometry_msgs/Twist or TwistStamped: the type its publisher has)
:Publishes:
  - ``odom`` (nav_msgs/Odometry), tf ``odom`` -> ``base_footprint``
"""
import threading

import rospy
import tf2_ros
from geometry_msgs.msg import Quaternion, TransformStamped
from nav_msgs.msg import Odometry

from battery_simulator.core import ros_names
from battery_simulator.robot import base
from battery_simulator.ros1.startup import init_node, read_private_settings
from battery_simulator.ros1.twist import TwistSubscriber


def read_settings():
    return read_private_settings(base.SETTINGS)


def yaw_quaternion(yaw):
    x, y, z, w = base.yaw_quaternion(yaw)
    return Quaternion(x=x, y=y, z=z, w=w)


class FakeBase:
    def __init__(self, rate, x, y, yaw, cmd_vel_timeout, odom_frame, base_frame):
        self._rate_hz = rate
        self._frames = (odom_frame, base_frame)
        self._lock = threading.Lock()   # guards _base
        self._base = base.Base(x, y, yaw, cmd_vel_timeout)
        self._odom_pub = rospy.Publisher(ros_names.ODOM, Odometry, queue_size=10)
        self._tf = tf2_ros.TransformBroadcaster()
        self._sub = TwistSubscriber(ros_names.CMD_VEL, self._on_cmd_vel)

    def _on_cmd_vel(self, twist, msg=None):
        linear, angular = twist.linear.x, twist.angular.z
        with self._lock:
            taken = self._base.command(linear, angular, rospy.get_time())
        if not taken:
            rospy.logerr_throttle(10.0, 'ignoring a non-finite cmd_vel (%r, %r)', linear, angular)

    def spin(self):
        rate = rospy.Rate(self._rate_hz, reset=True)   # ROS time; reset: a /clock jump back restarts it
        while not rospy.is_shutdown():
            with self._lock:
                stepped = self._base.step(rospy.get_time())
            if stepped is not None:   # None: ROS time has not moved (rospy.Rate may wake twice on a coarse tick)
                pose, (linear, angular) = stepped
                self._publish(self._base.time_s, pose, linear, angular)
            try:
                rate.sleep()
            except rospy.ROSInterruptException:
                break

    def _publish(self, now_s, pose, linear, angular):
        """odom and tf of the pose at ROS time ``now_s`` (the time integrated to, not a later tick's)."""
        x, y, yaw = pose
        stamp = rospy.Time.from_sec(now_s)
        odom = Odometry()
        odom.header.stamp, odom.header.frame_id = stamp, self._frames[0]
        odom.child_frame_id = self._frames[1]
        odom.pose.pose.position.x, odom.pose.pose.position.y = x, y
        odom.pose.pose.orientation = yaw_quaternion(yaw)
        odom.twist.twist.linear.x, odom.twist.twist.angular.z = linear, angular
        self._odom_pub.publish(odom)
        transform = TransformStamped()
        transform.header.stamp, transform.header.frame_id = stamp, self._frames[0]
        transform.child_frame_id = self._frames[1]
        transform.transform.translation.x, transform.transform.translation.y = x, y
        transform.transform.rotation = yaw_quaternion(yaw)
        self._tf.sendTransform(transform)


def main():
    FakeBase(**init_node('fake_base', read_settings)).spin()
