"""cmd_vel of either type on ROS 2 (core/velocity.py's rule): one process holds one type per topic name, so
the subscription takes the type the topic's publishers send (Nav2 Kilted: TwistStamped; most others: Twist),
looked up on the graph at most every TYPE_CHECK_S, and is made anew when that changes."""
import time

from geometry_msgs.msg import Twist, TwistStamped

from battery_simulator.core.velocity import TWIST, TWIST_STAMPED, twist_of, velocity_type_to_take

TYPE_CHECK_S = 2.0   # how often the publishers' types are looked up (a graph query; a fleet host has hundreds)
MESSAGE_CLASSES = {TWIST: Twist, TWIST_STAMPED: TwistStamped}


class VelocityInput:
    """A ``cmd_vel`` subscription on ``node`` that follows its publishers' type; ``on_twist(twist)`` gets the
    Twist of either message."""

    def __init__(self, node, topic, on_twist, qos=1):
        self._node = node
        self._topic = node.resolve_topic_name(topic)
        self._on_twist = on_twist
        self._qos = qos
        self.kind = TWIST
        self._checked_at = time.monotonic()
        self._subscription = self._subscribe()

    def _subscribe(self):
        return self._node.create_subscription(MESSAGE_CLASSES[self.kind], self._topic,
                                              lambda msg: self._on_twist(twist_of(msg)), self._qos)

    def follow_publishers(self, now=None):
        """Look up the publishers' type (at most every TYPE_CHECK_S) and take it: the new type, or None."""
        now = time.monotonic() if now is None else now
        if now - self._checked_at < TYPE_CHECK_S:
            return None
        self._checked_at = now
        wanted = velocity_type_to_take([info.topic_type for info in
                                        self._node.get_publishers_info_by_topic(self._topic)], self.kind)
        if wanted == self.kind:
            return None
        self._node.destroy_subscription(self._subscription)
        self.kind = wanted
        self._subscription = self._subscribe()
        return wanted
