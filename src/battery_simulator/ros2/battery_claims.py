"""One battery per robot name on ROS 2 (Part 3's rule): every process that runs batteries claims its names on a
latched topic, and of two claims on one name the earlier stays (ros2/local_claims.py decides at once for the
batteries of this machine)."""
import contextlib
import json
import os
import socket
import time

from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from std_msgs.msg import String

from battery_simulator.core import ros_names
from battery_simulator.ros2 import local_claims
from battery_simulator.ros2.startup import StartupError


# -- one battery per name (Part 3's rule on ROS 2) -----------------------------------------------------

#: every process that runs batteries says which names (namespaces) it serves, since when, on this topic
CLAIMS_TOPIC = ros_names.BATTERY_CLAIMS
CLAIMS_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1, reliability=ReliabilityPolicy.RELIABLE,
                        durability=DurabilityPolicy.TRANSIENT_LOCAL)
#: how long a process listens for the claims of others before it runs its batteries
CLAIM_WAIT_S = 1.5
#: ... and longer, up to this, while the graph shows a claim publisher whose claim has not arrived
CLAIM_WAIT_MOST_S = 6.0


def claimed_by(node, executor, namespace, timeout_s=1.0):
    """The battery node(s) of the process whose claim on /battery_claims holds ``namespace`` ('/robot1'), as
    that claim names them ('/battery_fleet (a fleet host)'), or None within ``timeout_s``."""
    found = []

    def on_claim(msg):
        with contextlib.suppress(ValueError, KeyError, TypeError):
            claim = json.loads(msg.data)
            if namespace in claim['names']:
                found.append(str(claim['node']))
    subscription = node.create_subscription(String, CLAIMS_TOPIC, on_claim, CLAIMS_QOS)
    deadline = time.monotonic() + timeout_s
    while not found and time.monotonic() < deadline:
        executor.spin_once(timeout_sec=0.05)
    node.destroy_subscription(subscription)
    return found[0] if found else None


class BatteryClaim:
    """This process's claim on battery names, and the rule that keeps one battery per name.

    Each process that runs a battery publishes (latched) the namespaces it serves with the moment it
    started (wall clock in ns, then host and pid: a total order) and listens to every other claim, from
    before its batteries start to its end. Of two claims on one name the earlier one stays; the later one
    exits with one line naming the other: at start-up after CLAIM_WAIT_S of listening, or, should
    discovery take longer than that, as soon as the earlier claim arrives. Two processes started in the
    same second both see both claims, so exactly one of them runs: no race is left to a graph lookup.
    """

    def __init__(self, node, names, what):
        """``names``: the namespaces served ('/robot1'); ``what``: this process's battery node(s) as a line
        names them ('/robot1/battery_simulator')."""
        self.node, self.names, self.what = node, sorted(set(names)), what
        self.order = (time.time_ns(), socket.gethostname(), os.getpid())
        self.lost = None
        self.on_lost = None
        self.heard = set()   # the orders of the other claims received (live or withdrawn)
        self._pub = None
        held = local_claims.register(self.names, what)   # this machine's batteries: decided at once
        if held is not None:
            holder, pid, taken = held
            self.lost = 'robot %s is already served by %s (pid %d, on this machine): exactly one battery per robot ' \
                        'name%s' % (taken[0].strip('/') or '/', holder, pid,
                                    '' if len(taken) == 1 else ' (%d of our robots are taken)' % len(taken))
            return   # no claim published: the earlier battery must not take ours for an earlier one
        self._sub = node.create_subscription(String, CLAIMS_TOPIC, self._on_claim, CLAIMS_QOS)
        self._pub = node.create_publisher(String, CLAIMS_TOPIC, CLAIMS_QOS)
        self._pub.publish(String(data=json.dumps({'order': list(self.order), 'names': self.names,
                                                   'node': what})))

    def _on_claim(self, msg):
        try:
            claim = json.loads(msg.data)
            order, names, node = tuple(claim['order']), set(claim['names']), str(claim['node'])
        except (ValueError, KeyError, TypeError):
            return
        if order != self.order:
            self.heard.add(order)
        shared = sorted(names.intersection(self.names))
        if self.lost is not None or not shared or order >= self.order:
            return
        name = shared[0]
        self.lost = ('robot %s is already served by %s (pid %s, started %.3f s before this one): exactly one '
                     'battery per robot name%s' % (
                         name.strip('/') or '/', node, order[2], (self.order[0] - order[0]) * 1e-9,
                         '' if len(shared) == 1 else ' (%d of our robots are taken)' % len(shared)))
        if self.on_lost is not None:
            self.node.get_logger().fatal(self.lost)
            self.on_lost()

    def release(self):
        """At the end: the claim withdrawn (no names), so that a process started while DDS still remembers this
        one's (latched) claim does not take it for a live one."""
        local_claims.unregister()
        with contextlib.suppress(Exception):
            self._pub.publish(String(data=json.dumps({'order': list(self.order), 'names': [], 'node': self.what})))

    def unheard(self):
        """How many claim publishers on the graph (other processes') have not delivered their claim yet."""
        return max(0, self.node.count_publishers(CLAIMS_TOPIC) - 1 - len(self.heard))

    def wait(self, executor, wait_s=CLAIM_WAIT_S, most_s=CLAIM_WAIT_MOST_S):
        """Listen ``wait_s`` for earlier claims, and on (at most ``most_s`` in all) while a claim publisher the
        graph shows has not delivered its claim: on a busy machine discovery takes longer than ``wait_s``, and a
        duplicate must be refused before it says it is ready. StartupError (the line) when a name is taken."""
        started = time.monotonic()
        while self.lost is None and self._pub is not None:
            now = time.monotonic()
            if now >= started + most_s or (now >= started + wait_s and not self.unheard()):
                break
            executor.spin_once(timeout_sec=0.05)
        if self.lost is not None:
            raise StartupError(self.lost)


# -- who serves this namespace's battery (a lone battery_state_pub asks, the tutorial's node) -------------

def battery_node_present(node):
    """Whether a node named battery_simulator runs in this node's namespace."""
    namespace = node.get_namespace()
    return any(name == ros_names.BATTERY_NODE and ns == namespace for name, ns in node.get_node_names_and_namespaces())


def other_state_pub(node):
    """Whether another node named as this one (battery_state_pub) runs in this node's namespace (battery_sim's)."""
    namespace, name = node.get_namespace(), node.get_name()
    return sum(1 for n, ns in node.get_node_names_and_namespaces() if n == name and ns == namespace) > 1


def status_published_by_battery(node, executor, timeout_s=1.0):
    """Whether this namespace's battery_simulator node publishes battery_status itself (a fleet host's
    robot does; battery_sim's battery leaves it to its battery_state_pub), looked for up to ``timeout_s``."""
    topic = node.resolve_topic_name(ros_names.BATTERY_STATUS)
    namespace = node.get_namespace()
    deadline = time.monotonic() + timeout_s
    while True:
        if any(info.node_name == ros_names.BATTERY_NODE and info.node_namespace == namespace
               for info in node.get_publishers_info_by_topic(topic)):
            return True
        if time.monotonic() >= deadline:
            return False
        executor.spin_once(timeout_sec=0.1)


def wait_for_battery_node(node, executor, wait_s):
    """Whether a battery_simulator node shows in this node's namespace within ``wait_s``."""
    deadline = time.monotonic() + wait_s
    while time.monotonic() < deadline:
        if battery_node_present(node):
            return True
        executor.spin_once(timeout_sec=0.1)
    return battery_node_present(node)


def check_no_second_publisher(node, executor):
    """StartupError when this namespace's battery_status already has a publisher (battery_sim's
    battery_state_pub, or a fleet host's robot): a second one would publish every battery_status twice."""
    if other_state_pub(node):
        raise StartupError('%s already runs beside the battery of %s (battery_sim runs both): a second '
                           'one would publish every battery_status twice; battery_state_pub alone is '
                           'for a namespace without battery_sim' % (
                               node.get_fully_qualified_name(), node.get_namespace()))
    if status_published_by_battery(node, executor):
        host = claimed_by(node, executor, node.get_namespace()) or '%s/%s' % (
            node.get_namespace().rstrip('/'), ros_names.BATTERY_NODE)
        raise StartupError('battery_status of %s is already published by %s (its battery and '
                           'battery_status are one node): a second battery_state_pub would publish '
                           'it twice; battery_state_pub alone is for a namespace without one' % (
                               node.get_namespace(), host))
