"""A kinematic differential-drive base for the demo (fake_base): no physics simulator needed.

It integrates the latest ``cmd_vel`` (held for ``~cmd_vel_timeout`` s, then
zero) into a pose, and publishes it as ``odom`` and as the tf odom ->
base_footprint, at ``~rate`` Hz. Everything runs on ROS time: under
``/use_sim_time`` with a coarse clock (0.24 s a tick at sim_clock speed 240) it
integrates over the ROS time that actually passed, exactly for a held Twist.

:ROS Parameters:
  - ``~rate`` (float, Hz, 0 < r <= 1000): integration and publication rate (default 20)
  - ``~x``, ``~y``, ``~yaw`` (float, m, m, rad): the start pose (default 0, 0, 0)
  - ``~cmd_vel_timeout`` (float, s > 0): a command older than this counts as stop (default 0.5)
  - ``~odom_frame``, ``~base_frame`` (str): frame ids (default odom, base_footprint)

:Subscribes:
  - ``cmd_vel`` (geometry_msgs/Twist)
:Publishes:
  - ``odom`` (nav_msgs/Odometry), tf ``odom`` -> ``base_footprint``
"""
import collections
import math
import threading

import rospy
import tf2_ros
from geometry_msgs.msg import Quaternion, TransformStamped, Twist
from nav_msgs.msg import Odometry

from battery_simulator.core import topics
from battery_simulator.ros1.startup import checked_param, init_node, is_number


def read_settings():
    return dict(
        rate=checked_param('~rate', 20.0, lambda v: is_number(v) and 0 < v <= 1000, 'a number in (0, 1000] Hz'),
        x=checked_param('~x', 0.0, is_number, 'a number (m)'),
        y=checked_param('~y', 0.0, is_number, 'a number (m)'),
        yaw=checked_param('~yaw', 0.0, is_number, 'a number (rad)'),
        cmd_vel_timeout=checked_param('~cmd_vel_timeout', 0.5, lambda v: is_number(v) and v > 0, 'a number > 0 s'),
        odom_frame=checked_param('~odom_frame', 'odom', lambda v: isinstance(v, str) and v, 'a frame id'),
        base_frame=checked_param('~base_frame', 'base_footprint', lambda v: isinstance(v, str) and v, 'a frame id'),
    )


def integrate(x, y, yaw, linear, angular, dt_s):
    """The pose after driving at (linear, angular) for dt_s (exact arc for a unicycle)."""
    if abs(angular) < 1e-9:
        return x + linear * dt_s * math.cos(yaw), y + linear * dt_s * math.sin(yaw), yaw
    new_yaw = yaw + angular * dt_s
    radius = linear / angular
    return (x + radius * (math.sin(new_yaw) - math.sin(yaw)),
            y - radius * (math.cos(new_yaw) - math.cos(yaw)),
            math.atan2(math.sin(new_yaw), math.cos(new_yaw)))


def advance(pose, command, last_s, now_s, timeout_s):
    """(pose, moving) after the ROS time from ``last_s`` to ``now_s``: ``command`` = (linear, angular,
    received_s) drives from ``last_s`` until it times out (exact: one arc), then the base stands."""
    linear, angular, received_s = command
    moving_s = min(now_s, received_s + timeout_s) - last_s
    if moving_s <= 0.0:
        return pose, False
    return integrate(*pose, linear, angular, moving_s), now_s - received_s <= timeout_s


def yaw_quaternion(yaw):
    return Quaternion(x=0.0, y=0.0, z=math.sin(yaw / 2.0), w=math.cos(yaw / 2.0))


class FakeBase:
    def __init__(self, rate, x, y, yaw, cmd_vel_timeout, odom_frame, base_frame):
        self._rate_hz = rate
        self._pose = (x, y, yaw)
        self._timeout_s = cmd_vel_timeout
        self._frames = (odom_frame, base_frame)
        self._lock = threading.Lock()   # guards _command
        self._steps = collections.deque(maxlen=20)   # the last steps of ROS time seen (s): the clock's tick
        self._command = (0.0, 0.0, -math.inf)   # (linear, angular, ROS time received)
        self._odom_pub = rospy.Publisher(topics.ODOM, Odometry, queue_size=10)
        self._tf = tf2_ros.TransformBroadcaster()
        self._sub = rospy.Subscriber(topics.CMD_VEL, Twist, self._on_cmd_vel, queue_size=1)

    def _on_cmd_vel(self, twist):
        linear, angular = twist.linear.x, twist.angular.z
        if not (math.isfinite(linear) and math.isfinite(angular)):
            rospy.logerr_throttle(10.0, 'ignoring a non-finite cmd_vel (%r, %r)', linear, angular)
            return
        with self._lock:
            self._command = (linear, angular, rospy.get_time())

    def spin(self):
        rate = rospy.Rate(self._rate_hz, reset=True)   # ROS time; reset: a /clock jump back restarts it
        last = rospy.get_time()
        while not rospy.is_shutdown():
            now = rospy.get_time()
            with self._lock:
                command = self._command
            if now < last or last == 0.0:   # a clock jump back, or no /clock yet: restart from here
                last = now
            elif now == last:   # ROS time has not moved (rospy.Rate may wake twice on a coarse tick)
                self._sleep(rate)
                continue
            if now > last:
                self._steps.append(now - last)
            # a command holds for its timeout, or one and a half ticks of a coarse clock (the shortest
            # recent step), never for a stall's whole length
            timeout_s = max(self._timeout_s, 1.5 * min(self._steps, default=0.0))
            self._pose, moving = advance(self._pose, command, last, now, timeout_s)
            last = now
            self._publish(now, *(command[:2] if moving else (0.0, 0.0)))
            if not self._sleep(rate):
                break

    @staticmethod
    def _sleep(rate):
        try:
            rate.sleep()
            return True
        except rospy.ROSInterruptException:
            return False

    def _publish(self, now_s, linear, angular):
        """odom and tf of the pose at ROS time ``now_s`` (the time integrated to, not a later tick's)."""
        x, y, yaw = self._pose
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
