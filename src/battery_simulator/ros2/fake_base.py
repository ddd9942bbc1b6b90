"""``fake_base`` (ROS 2): a kinematic differential-drive base for the demo, as ROS 1's fake_base.py.

It integrates the latest ``cmd_vel`` (geometry_msgs/msg/Twist or TwistStamped, held for
``cmd_vel_timeout`` s of ROS time, then zero) into a pose (robot/base.py), and publishes it on ``odom``
(nav_msgs/msg/Odometry) and, where tf2_msgs is installed, as the tf odom -> base_footprint on ``/tf``, at
``rate`` Hz of ROS time: under ``use_sim_time`` it integrates over the ROS time that actually passed.

:Parameters: ``rate`` (Hz, default 20), ``x``, ``y``, ``yaw`` (the start pose), ``cmd_vel_timeout`` (s, 0.5),
  ``odom_frame`` (odom), ``base_frame`` (base_footprint)
"""
from geometry_msgs.msg import TransformStamped
from nav_msgs.msg import Odometry

from battery_simulator.core import ros_names
from battery_simulator.robot import base
from battery_simulator.ros2.startup import run_node
from battery_simulator.ros2.twist import TwistSubscriber

try:
    from tf2_msgs.msg import TFMessage
except ImportError:   # the PyPI wheels of tools/ros2.sh have no tf2_msgs: odometry only
    TFMessage = None


def seconds(clock):
    return clock.now().nanoseconds * 1e-9


class FakeBase:
    def __init__(self, node, rate, x, y, yaw, cmd_vel_timeout, odom_frame, base_frame):
        self._node = node
        self._frames = (odom_frame, base_frame)
        self._base = base.Base(x, y, yaw, cmd_vel_timeout)
        self._odom_pub = node.create_publisher(Odometry, ros_names.ODOM, 10)
        self._tf_pub = node.create_publisher(TFMessage, '/tf', 100) if TFMessage is not None else None
        if self._tf_pub is None:
            node.get_logger().info('no tf2_msgs here: odometry only, no tf odom -> %s' % base_frame)
        self._sub = TwistSubscriber(node, ros_names.CMD_VEL, self._on_cmd_vel)
        self._timer = node.create_timer(1.0 / rate, self._step)   # the node's clock: ROS time under use_sim_time

    def _on_cmd_vel(self, twist, msg):
        linear, angular = twist.linear.x, twist.angular.z
        if not self._base.command(linear, angular, seconds(self._node.get_clock())):
            self._node.get_logger().error('ignoring a non-finite cmd_vel (%r, %r)' % (linear, angular),
                                          throttle_duration_sec=10.0)

    def _step(self):
        now = self._node.get_clock().now()
        stepped = self._base.step(now.nanoseconds * 1e-9)
        if stepped is None:   # ROS time has not moved
            return
        (x, y, yaw), (linear, angular) = stepped
        stamp = now.to_msg()
        qx, qy, qz, qw = base.yaw_quaternion(yaw)
        odom = Odometry()
        odom.header.stamp, odom.header.frame_id = stamp, self._frames[0]
        odom.child_frame_id = self._frames[1]
        odom.pose.pose.position.x, odom.pose.pose.position.y = x, y
        odom.pose.pose.orientation.z, odom.pose.pose.orientation.w = qz, qw
        odom.twist.twist.linear.x, odom.twist.twist.angular.z = linear, angular
        self._odom_pub.publish(odom)
        if self._tf_pub is not None:
            transform = TransformStamped()
            transform.header = odom.header
            transform.child_frame_id = self._frames[1]
            transform.transform.translation.x, transform.transform.translation.y = x, y
            transform.transform.rotation = odom.pose.pose.orientation
            self._tf_pub.publish(TFMessage(transforms=[transform]))


def main(args=None):
    run_node('fake_base', base.SETTINGS, FakeBase, args)
