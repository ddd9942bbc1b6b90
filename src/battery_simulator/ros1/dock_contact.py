"""The charger contact of a dock (battery_dock_contact).

True while the robot stands within ``~radius`` of the dock, slower than
``~max_speed``: what a real dock's contact plates report. Published on every
change and at least once a second (latched), for the server's charger contact.
The rule is robot/dock_contact.py's.

:ROS Parameters:
  - ``~dock_x``, ``~dock_y`` (float, m): the dock in the odom frame (default 0, 0)
  - ``~radius`` (float, m > 0): contact within this distance (default 0.3)
  - ``~max_speed`` (float, m/s > 0): and slower than this (default 0.05)

:Subscribes:
  - ``odom`` (nav_msgs/Odometry)
:Publishes:
  - ``charger_contact`` (std_msgs/Bool, latched)
"""
import threading

import rospy
from nav_msgs.msg import Odometry
from std_msgs.msg import Bool

from battery_simulator.core import ros_names
from battery_simulator.robot import dock_contact as rule
from battery_simulator.ros1.startup import init_node, read_private_settings


def read_settings():
    return read_private_settings(rule.SETTINGS)


class DockContact:
    def __init__(self, dock_x, dock_y, radius, max_speed):
        self._lock = threading.Lock()   # guards _contact
        self._contact = rule.DockContact(dock_x, dock_y, radius, max_speed)
        self._pub = rospy.Publisher(ros_names.CHARGER_CONTACT, Bool, queue_size=1, latch=True)
        self._sub = rospy.Subscriber(ros_names.ODOM, Odometry, self._on_odom, queue_size=1)

    def _on_odom(self, odom):
        position, twist = odom.pose.pose.position, odom.twist.twist
        try:
            with self._lock:
                changed = self._contact.update(position.x, position.y, twist.linear.x, twist.linear.y)
        except ValueError as error:
            rospy.logwarn_throttle(10.0, str(error))
            return
        if changed is not None:
            rospy.loginfo('charger contact: %s (at %.2f, %.2f)', changed, position.x, position.y)
            self._pub.publish(Bool(data=changed))

    def spin(self):
        rate = rospy.Rate(1.0 / rule.REPEAT_PERIOD_S, reset=True)   # ROS time, as the robot moves; reset: jumps
        self._pub.publish(Bool(data=False))
        while not rospy.is_shutdown():
            with self._lock:
                contact = self._contact.contact
            self._pub.publish(Bool(data=contact))
            try:
                rate.sleep()
            except rospy.ROSInterruptException:
                break


def main():
    DockContact(**init_node('battery_dock_contact', read_settings)).spin()
