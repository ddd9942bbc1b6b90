"""``battery_dock_contact`` (ROS 2): the charger contact of a dock, as ROS 1's battery_dock_contact.py.

True while the robot stands within ``radius`` m of (``dock_x``, ``dock_y``) in the odom frame, slower than
``max_speed`` (robot/dock_contact.py); published on ``charger_contact`` (std_msgs/msg/Bool, reliable,
transient local: ROS 2's latched) on every change and twice a second of ROS time.

:Subscribes: ``odom`` (nav_msgs/msg/Odometry)
:Parameters: ``dock_x``, ``dock_y`` (m, default 0), ``radius`` (m, 0.3), ``max_speed`` (m/s, 0.05)
"""
from nav_msgs.msg import Odometry
from std_msgs.msg import Bool

from battery_simulator.core import ros_names
from battery_simulator.robot import dock_contact as rule
from battery_simulator.ros2.qos import LATCHED_QOS
from battery_simulator.ros2.startup import run_node


class DockContact:
    def __init__(self, node, dock_x, dock_y, radius, max_speed):
        self._node = node
        self._contact = rule.DockContact(dock_x, dock_y, radius, max_speed)
        self._pub = node.create_publisher(Bool, ros_names.CHARGER_CONTACT, LATCHED_QOS)
        self._sub = node.create_subscription(Odometry, ros_names.ODOM, self._on_odom, 10)
        self._pub.publish(Bool(data=False))
        self._timer = node.create_timer(rule.REPEAT_PERIOD_S, self._repeat)   # ROS time, as the robot moves

    def _on_odom(self, odom):
        position, twist = odom.pose.pose.position, odom.twist.twist
        try:
            changed = self._contact.update(position.x, position.y, twist.linear.x, twist.linear.y)
        except ValueError as error:
            self._node.get_logger().warning(str(error), throttle_duration_sec=10.0)
            return
        if changed is not None:
            self._node.get_logger().info('charger contact: %s (at %.2f, %.2f)' % (changed, position.x, position.y))
            self._pub.publish(Bool(data=changed))

    def _repeat(self):
        self._pub.publish(Bool(data=self._contact.contact))


def main(args=None):
    run_node('battery_dock_contact', rule.SETTINGS, DockContact, args)
