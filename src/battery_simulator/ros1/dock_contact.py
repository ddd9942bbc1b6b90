"""The charger contact of a dock (battery_dock_contact).

True while the robot stands within ``~radius`` of the dock, slower than
``~max_speed``: what a real dock's contact plates report. Published on every
change and at least once a second (latched), for the server's charger contact.

:ROS Parameters:
  - ``~dock_x``, ``~dock_y`` (float, m): the dock in the odom frame (default 0, 0)
  - ``~radius`` (float, m > 0): contact within this distance (default 0.3)
  - ``~max_speed`` (float, m/s > 0): and slower than this (default 0.05)

:Subscribes:
  - ``odom`` (nav_msgs/Odometry)
:Publishes:
  - ``charger_contact`` (std_msgs/Bool, latched)
"""
import math
import threading

import rospy
from nav_msgs.msg import Odometry
from std_msgs.msg import Bool

from battery_simulator.core import topics
from battery_simulator.ros1.startup import checked_param, init_node, is_number

REPEAT_PERIOD_S = 0.5


def read_settings():
    return dict(
        dock_x=checked_param('~dock_x', 0.0, is_number, 'a number (m)'),
        dock_y=checked_param('~dock_y', 0.0, is_number, 'a number (m)'),
        radius=checked_param('~radius', 0.3, lambda v: is_number(v) and v > 0, 'a number > 0 m'),
        max_speed=checked_param('~max_speed', 0.05, lambda v: is_number(v) and v > 0, 'a number > 0 m/s'),
    )


def in_contact(x, y, speed, dock_x, dock_y, radius, max_speed):
    """Whether a robot at (x, y) moving at ``speed`` touches the dock's contacts."""
    return math.hypot(x - dock_x, y - dock_y) <= radius and speed < max_speed


class DockContact:
    def __init__(self, dock_x, dock_y, radius, max_speed):
        self._dock = dict(dock_x=dock_x, dock_y=dock_y, radius=radius, max_speed=max_speed)
        self._lock = threading.Lock()   # guards _contact
        self._contact = False
        self._pub = rospy.Publisher(topics.CHARGER_CONTACT, Bool, queue_size=1, latch=True)
        self._sub = rospy.Subscriber(topics.ODOM, Odometry, self._on_odom, queue_size=1)

    def _on_odom(self, odom):
        position, twist = odom.pose.pose.position, odom.twist.twist
        speed = math.hypot(twist.linear.x, twist.linear.y)
        if not all(math.isfinite(value) for value in (position.x, position.y, speed)):
            rospy.logwarn_throttle(10.0, 'ignoring odometry with a non-finite position or speed '
                                   '(x %r, y %r, speed %r); contact stays %s', position.x, position.y, speed,
                                   self._contact)
            return
        contact = in_contact(position.x, position.y, speed, **self._dock)
        with self._lock:
            changed, self._contact = contact != self._contact, contact
        if changed:
            rospy.loginfo('charger contact: %s', contact)
            self._pub.publish(Bool(data=contact))

    def spin(self):
        rate = rospy.Rate(1.0 / REPEAT_PERIOD_S, reset=True)   # ROS time, as the robot moves; reset: clock jumps
        self._pub.publish(Bool(data=False))
        while not rospy.is_shutdown():
            with self._lock:
                contact = self._contact
            self._pub.publish(Bool(data=contact))
            try:
                rate.sleep()
            except rospy.ROSInterruptException:
                break


def main():
    DockContact(**init_node('battery_dock_contact', read_settings)).spin()
