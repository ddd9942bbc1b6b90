"""Velocity commands of either type on ROS 2: geometry_msgs/msg/Twist or TwistStamped (Nav2 Kilted's default),
the type a topic's publishers have, looked up on the graph (ros1/twist.py is ROS 1's)."""
from geometry_msgs.msg import Twist, TwistStamped

from battery_simulator.ros2.robot_node import steady_clock

TYPE_CHECK_PERIOD_S = 0.5   # wall seconds between looks at a velocity topic's publishers' type
TYPES = {'geometry_msgs/msg/Twist': Twist, 'geometry_msgs/msg/TwistStamped': TwistStamped}


def twist_of(msg):
    """The Twist inside a Twist or TwistStamped."""
    return msg.twist if isinstance(msg, TwistStamped) else msg


class TwistSubscriber:
    """Subscribes ``topic`` with the type its publishers have (Twist until only TwistStamped publishers are
    seen); ``callback(twist, msg)``. A change of type resubscribes within TYPE_CHECK_PERIOD_S."""

    def __init__(self, node, topic, callback, qos=10):
        self._node, self._callback, self._qos = node, callback, qos
        self._topic = node.resolve_topic_name(topic)
        self.msg_type = Twist
        self._sub = node.create_subscription(Twist, self._topic, self._on_message, qos)
        self._timer = node.create_timer(TYPE_CHECK_PERIOD_S, self._check_type, clock=steady_clock())

    def _check_type(self):
        kinds = {TYPES.get(info.topic_type) for info in self._node.get_publishers_info_by_topic(self._topic)}
        kinds.discard(None)
        if len(kinds) == 1 and self.msg_type not in kinds:
            self._node.destroy_subscription(self._sub)
            self.msg_type = kinds.pop()
            self._sub = self._node.create_subscription(self.msg_type, self._topic, self._on_message, self._qos)
            self._node.get_logger().info('%s: taking %s' % (self._topic, self.msg_type.__name__))

    def _on_message(self, msg):
        self._callback(twist_of(msg), msg)


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
