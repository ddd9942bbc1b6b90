"""Velocity commands of either type on ROS 2 for the robot's loop (core/velocity.py's rule, ros2/velocity.py's
subscription): geometry_msgs/msg/Twist or TwistStamped, the type a topic's publishers send (looked up on the
graph), and the gate's output publishing the type it forwards (ros1/twist.py is ROS 1's)."""
from geometry_msgs.msg import Twist, TwistStamped

from battery_simulator.core.velocity import twist_of
from battery_simulator.ros2.startup import steady_clock
from battery_simulator.ros2.velocity import MESSAGE_CLASSES, TYPE_CHECK_S, VelocityInput


class TwistSubscriber(VelocityInput):
    """VelocityInput that follows its publishers' type on a timer of its own (every TYPE_CHECK_S wall seconds)
    and hands ``callback(twist, msg)`` the message too: the gate forwards it as it came."""

    def __init__(self, node, topic, callback, qos=10):
        self._callback = callback
        super().__init__(node, topic, None, qos)
        self._timer = node.create_timer(TYPE_CHECK_S / 2.0, self._follow, clock=steady_clock())

    def _subscribe(self):
        return self._node.create_subscription(MESSAGE_CLASSES[self.kind], self._topic,
                                              lambda msg: self._callback(twist_of(msg), msg), self._qos)

    def _follow(self):
        if self.follow_publishers() is not None:
            self._node.get_logger().info('%s: taking %s' % (self._topic, self.kind))


class TwistPublisher:
    """Publishes on ``topic`` the type last given (Twist until a TwistStamped comes): the gate forwards what it
    receives. A change of type re-creates the publisher with the new type."""

    def __init__(self, node, topic, qos=10):
        self._node, self._topic, self._qos = node, topic, qos
        self._type = Twist
        self._pub = node.create_publisher(Twist, topic, qos)
        self._frame_id = ''

    def publish(self, msg):
        if type(msg) is not self._type:
            self._node.destroy_publisher(self._pub)
            self._type = type(msg)
            self._pub = self._node.create_publisher(self._type, self._topic, self._qos)
        if isinstance(msg, TwistStamped):
            self._frame_id = msg.header.frame_id
        self._pub.publish(msg)

    def publish_stop(self, like=None):
        """A zero command of the type of ``like`` (default: the type last forwarded), stamped now in the frame
        last seen."""
        if (type(like) if like is not None else self._type) is TwistStamped:
            stop = TwistStamped()
            stop.header.frame_id = like.header.frame_id if like is not None else self._frame_id
            stop.header.stamp = self._node.get_clock().now().to_msg()
            self.publish(stop)
        else:
            self.publish(Twist())
