"""cmd_vel of either type on ROS 2 (core/velocity.py's rule): one process holds one type per topic name, so
the subscription takes the type the topic's publishers send (Nav2 Kilted: TwistStamped; most others: Twist),
looked up on the graph at most every TYPE_CHECK_S, and is made anew when that changes."""
import time

from geometry_msgs.msg import Twist, TwistStamped

from battery_simulator.core.velocity import TWIST, TWIST_STAMPED, twist_of, velocity_type_to_take

TYPE_CHECK_S = 2.0   # how often the publishers' types are looked up (a graph query; a fleet host has hundreds)
MESSAGE_CLASSES = {TWIST: Twist, TWIST_STAMPED: TwistStamped}


#: the graph's type names of the two messages, as get_topic_names_and_types gives them
TYPE_NAMES = {TWIST: 'geometry_msgs/msg/Twist', TWIST_STAMPED: 'geometry_msgs/msg/TwistStamped'}


class GraphTypes:
    """Every topic's types on the graph, looked up at most every TYPE_CHECK_S in one query, for the many
    VelocityInputs of one node (a fleet host): a per-topic publishers query scans the whole graph, 4.5 ms a call
    with 250 robots (a third of the host's CPU when every robot asked every 2 s)."""

    def __init__(self, node):
        self._node = node
        self._types = {}
        self._at = None

    def __call__(self, now):
        if self._at is None or now - self._at >= TYPE_CHECK_S:
            self._at = now
            self._types = dict(self._node.get_topic_names_and_types())
        return self._types


class VelocityInput:
    """A ``cmd_vel`` subscription on ``node`` that follows its publishers' type; ``on_twist(twist)`` gets the
    Twist of either message. ``graph_types``: a shared GraphTypes (a fleet host's): the publishers are looked
    up only when the topic shows a type other than the one taken."""

    def __init__(self, node, topic, on_twist, qos=1, graph_types=None):
        self._node = node
        self._graph_types = graph_types
        self._topic = node.resolve_topic_name(topic)
        self._on_twist = on_twist
        self._qos = qos
        self.kind = TWIST
        self._checked_at = time.monotonic()
        self._subscription = self._subscribe()

    def _subscribe(self):
        return self._node.create_subscription(MESSAGE_CLASSES[self.kind], self._topic,
                                              lambda msg: self._on_twist(twist_of(msg)), self._qos)

    def _resubscribe(self):
        """The subscription of the type taken, once the old one is gone: an executor that holds the old one (rclpy's
        EventsExecutor, a fleet host's) destroys it at its next turn, and until then DDS refuses a second type on
        the name. True once it exists."""
        try:
            self._subscription = self._subscribe()
        except Exception:   # rclpy's RCLError: "existing topic name ... with incompatible type"
            return False
        return True

    def follow_publishers(self, now=None):
        """Look up the publishers' type (at most every TYPE_CHECK_S) and take it: the new type, or None."""
        now = time.monotonic() if now is None else now
        if self._subscription is None:
            return self.kind if self._resubscribe() else None
        if now - self._checked_at < TYPE_CHECK_S:
            return None
        self._checked_at = now
        if self._graph_types is not None and \
                set(self._graph_types(now).get(self._topic, ())) <= {TYPE_NAMES[self.kind]}:
            return None   # no publisher, or only of the type taken: nothing to change
        wanted = velocity_type_to_take([info.topic_type for info in
                                        self._node.get_publishers_info_by_topic(self._topic)], self.kind)
        if wanted == self.kind:
            return None
        self._node.destroy_subscription(self._subscription)
        self._subscription = None
        self.kind = wanted
        return wanted if self._resubscribe() else None
