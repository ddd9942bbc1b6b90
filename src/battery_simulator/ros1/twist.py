"""Velocity commands of either type on ROS 1 for the robot's loop (core/velocity.py): geometry_msgs/Twist or
TwistStamped, told apart by each publisher's connection header; the gate's output publishes the type it
forwards."""
import rosgraph
import rospy
from geometry_msgs.msg import Twist, TwistStamped

from battery_simulator.core.velocity import twist_of
from battery_simulator.ros1.velocity import MESSAGE_CLASSES as TYPES, velocity_of_any


class TwistSubscriber:
    """Subscribes ``topic`` with whatever of the two types its publishers have; ``callback(twist, msg)``."""

    def __init__(self, topic, callback, queue_size=1):
        self._callback = callback
        self._sub = rospy.Subscriber(topic, rospy.AnyMsg, self._on_message, queue_size=queue_size)

    def _on_message(self, raw):
        msg = velocity_of_any(raw)
        if msg is None:
            rospy.logwarn_throttle(10.0, 'ignoring a %s on %s: takes geometry_msgs/Twist or TwistStamped',
                                   raw._connection_header.get('type', ''), self._sub.resolved_name)
            return
        self._callback(twist_of(msg), msg)


def known_type(topics):
    """The message class the master knows for the first of ``topics`` that it knows as Twist or TwistStamped
    (a subscriber registers its type too), else Twist."""
    try:
        known = dict(rosgraph.Master(rospy.get_name()).getTopicTypes())
    except (OSError, rosgraph.MasterException):
        return Twist
    for topic in topics:
        if known.get(rospy.resolve_name(topic)) in TYPES:
            return TYPES[known[rospy.resolve_name(topic)]]
    return Twist


class TwistPublisher:
    """Publishes on ``topic`` the type last given: the gate forwards what it receives. It starts with the type
    the master knows for ``topic`` or ``like_topics`` (Twist if none), and a change of type re-advertises the
    topic (a typed subscriber of the other type reconnects then)."""

    def __init__(self, topic, queue_size=10, like_topics=()):
        self._topic, self._queue_size = topic, queue_size
        self._type = known_type((topic,) + tuple(like_topics))
        self._pub = rospy.Publisher(topic, self._type, queue_size=queue_size)
        self._frame_id = ''

    def publish(self, msg):
        if type(msg) is not self._type:
            self._pub.unregister()
            self._type = type(msg)
            self._pub = rospy.Publisher(self._topic, self._type, queue_size=self._queue_size)
        if isinstance(msg, TwistStamped):
            self._frame_id = msg.header.frame_id
        self._pub.publish(msg)

    def publish_stop(self, like=None):
        """A zero command of the type of ``like`` (default: the type last forwarded), stamped now in the frame
        last seen."""
        if (type(like) if like is not None else self._type) is TwistStamped:
            stop = TwistStamped()
            stop.header.frame_id = like.header.frame_id if like is not None else self._frame_id
            stop.header.stamp = rospy.Time.now()
            self.publish(stop)
        else:
            self.publish(Twist())
