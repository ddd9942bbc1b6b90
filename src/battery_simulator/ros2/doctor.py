"""``battery_doctor`` (ROS 2): what a live graph of batteries and their consumers gets wrong.

    ros2 run battery_simulator battery_doctor [--wait S] [--sample S] [--ros-args ...]

Waits ``--wait`` seconds (default 5) for discovery, lists every battery publisher and every
subscriber of a battery or velocity topic with its type and QoS (reliability, durability, depth
where discovery tells it), samples each battery topic (one best-effort volatile subscription, which
every publisher matches; each message credited to its publisher's GID) for ``--sample`` seconds
(default 3) from the moment it is matched to every publisher, then prints one line per finding
(core/doctor.py's rules) and an ``unsampled:`` line for the topics it could not hear out. Exit 0 when
clean and every battery topic sampled, 1 when it found something or left a topic unsampled, 2 for a
bad command line or an empty graph.
"""
import sys
import time

from battery_simulator.core import doctor

STEP_S = 0.05
#: how long past ``--sample`` the doctor waits for its subscriptions to be matched to every publisher
#: (discovery of 200 new subscriptions on a busy machine takes seconds)
MATCH_ALLOWANCE_S = 5.0
#: during --wait, the battery topics discovery shows are subscribed from this far in, and again every period
FIRST_LOOK_S = 0.5
LOOK_PERIOD_S = 1.0
#: the default discovery wait: Fast DDS announces a participant every 3 s, and one outside another's
#: initial-peer range (127.0.0.1, the first few participant ids) is found only by that announcement
#: (2 s missed the test process's endpoints in test_consumers.py, 4 s found them)
DISCOVERY_WAIT_S = 5.0


def _endpoint(info):
    from rclpy.qos import DurabilityPolicy, ReliabilityPolicy
    qos = info.qos_profile
    reliability = {ReliabilityPolicy.RELIABLE: doctor.RELIABLE,
                   ReliabilityPolicy.BEST_EFFORT: doctor.BEST_EFFORT}.get(qos.reliability, str(qos.reliability.name).lower())
    durability = {DurabilityPolicy.VOLATILE: doctor.VOLATILE,
                  DurabilityPolicy.TRANSIENT_LOCAL: doctor.TRANSIENT_LOCAL}.get(qos.durability,
                                                                                str(qos.durability.name).lower())
    node = (info.node_namespace.rstrip('/') + '/' + info.node_name) if info.node_name else '(unknown node)'
    # discovery carries no history depth (remote endpoints report 0): unknown, not 0
    return doctor.Endpoint(node, info.topic_type, reliability, durability, qos.depth or None,
                           gid_text(info.endpoint_gid))


def gid_text(gid):
    """An endpoint's GID as hex, from the graph's endpoint info (a sequence of ints) or a received message's
    info (a dict with 'data'): the first 16 bytes, what both carry."""
    if isinstance(gid, dict):
        gid = gid.get('data', b'')
    return bytes(gid)[:16].hex() if gid is not None else None


def describe(node):
    """The graph as ``node`` sees it now: every battery or velocity topic, without ``node``'s own endpoints."""
    own = node.get_fully_qualified_name()
    graph = doctor.Graph(has_qos=True)
    for name, types in node.get_topic_names_and_types():
        if not doctor.topic_of_interest(name, types):
            continue
        publishers = [_endpoint(i) for i in node.get_publishers_info_by_topic(name)]
        subscribers = [_endpoint(i) for i in node.get_subscriptions_info_by_topic(name)]
        publishers = [e for e in publishers if e.node != own]
        subscribers = [e for e in subscribers if e.node != own]
        if publishers or subscribers:
            topic = graph.topic(name)
            topic.publishers += publishers
            topic.subscribers += subscribers
    return graph


#: the sampler's QoS: best effort and volatile match every publisher (reliable or not, transient local or not)
def _sampling_qos():
    from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
    return QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=10, reliability=ReliabilityPolicy.BEST_EFFORT,
                      durability=DurabilityPolicy.VOLATILE)


class Sampler:
    """One subscription a published battery topic, made as soon as discovery shows the topic (during
    ``--wait``: a busy host matching 200 new subscriptions needs those seconds before it sends to them),
    every message credited to the publisher that sent it (its GID)."""

    def __init__(self, node):
        self.node = node
        self.records = {}   # topic name -> {'samples', 'subscription', 'publishers', 'since'}

    def subscribe(self, graph):
        """Subscribe to every published battery topic of ``graph`` not subscribed yet."""
        from sensor_msgs.msg import BatteryState

        def _record(samples, msg, info):
            samples.append(doctor.Sample(float(msg.percentage), float(msg.current), int(msg.power_supply_status),
                                         float(msg.voltage), gid_text(info.get('publisher_gid'))))
        for name, topic in sorted(graph.topics.items()):
            publishers = len({e.key for e in topic.battery_publishers()})
            if not publishers:
                continue
            if name in self.records:
                self.records[name]['publishers'] = publishers
                continue
            samples = []
            subscription = self.node.create_subscription(
                BatteryState, name, lambda msg, info, samples=samples: _record(samples, msg, info), _sampling_qos())
            self.records[name] = {'samples': samples, 'subscription': subscription, 'publishers': publishers,
                                  'since': None}

    def track(self, now):
        """Note when each subscription is matched to every publisher its topic has."""
        for record in self.records.values():
            if record['since'] is None and record['subscription'].get_publisher_count() >= record['publishers']:
                record['since'] = now

    def run(self, graph, seconds):
        """Sample ``graph``'s battery topics: a topic is done when each publisher sent a message and it has
        doctor.SAMPLES_PER_TOPIC; its window of ``seconds`` starts when its subscription is matched to every
        publisher (``Topic.heard``: how long, at the end). Ends when every topic is done or heard out, and at
        the latest ``seconds`` + MATCH_ALLOWANCE_S from now."""
        import rclpy
        self.subscribe(graph)
        pending = {}
        for name, topic in graph.topics.items():
            if name in self.records and topic.battery_publishers():
                topic.sampled_s = seconds
                topic.samples = self.records[name]['samples']
                pending[name] = topic
        hard_deadline = time.monotonic() + seconds + max(seconds, MATCH_ALLOWANCE_S)
        while pending:
            rclpy.spin_once(self.node, timeout_sec=STEP_S)
            now = time.monotonic()
            self.track(now)
            for name, topic in list(pending.items()):
                since = self.records[name]['since']
                if since is not None:
                    topic.heard = now - since
                done = len(topic.samples) >= doctor.SAMPLES_PER_TOPIC and not doctor.unheard(topic)
                if done or (since is not None and now - since >= seconds) or now >= hard_deadline:
                    del pending[name]

    def close(self):
        for record in self.records.values():
            self.node.destroy_subscription(record['subscription'])
        self.records = {}


def _other_nodes(node):
    own = node.get_fully_qualified_name()
    return [(ns.rstrip('/') + '/' + name) for name, ns in node.get_node_names_and_namespaces()
            if (ns.rstrip('/') + '/' + name) != own]


def main(argv=None):
    argv = sys.argv[1:] if argv is None else argv
    ros_args = argv[argv.index('--ros-args'):] if '--ros-args' in argv else []
    ours = argv[:argv.index('--ros-args')] if ros_args else argv
    try:
        options = doctor.parse_arguments(ours, wait_s=DISCOVERY_WAIT_S)
    except doctor.UsageError as error:
        print(error, file=sys.stderr)
        sys.exit(doctor.EXIT_USAGE)
    import os

    import rclpy
    from rclpy.signals import SignalHandlerOptions

    from battery_simulator.ros2.rcl_args import init_rclpy

    init_rclpy('battery_doctor', ['battery_doctor'] + ros_args, signal_handler_options=SignalHandlerOptions.NO)
    code = doctor.EXIT_USAGE
    try:
        node = rclpy.create_node('battery_doctor', start_parameter_services=False)
        sampler = Sampler(node)
        started = time.monotonic()
        deadline, next_look = started + options['wait'], started + FIRST_LOOK_S
        while time.monotonic() < deadline:
            rclpy.spin_once(node, timeout_sec=STEP_S)
            now = time.monotonic()
            sampler.track(now)
            if now >= next_look:   # subscribe to what discovery shows so far: matching takes the rest of --wait
                sampler.subscribe(describe(node))
                next_look = now + LOOK_PERIOD_S
        if not _other_nodes(node):
            print('battery_doctor: no other node on the ROS 2 graph (ROS_DOMAIN_ID=%s) within %g s: start the '
                  'robot first, or give a longer --wait' % (os.environ.get('ROS_DOMAIN_ID', '0'), options['wait']),
                  file=sys.stderr)
            return
        graph = describe(node)
        sampler.run(graph, options['sample'])
        sampler.close()
        lines, code = doctor.report(graph)
        print('\n'.join(lines), flush=True)
    except KeyboardInterrupt:
        code = 130
    finally:
        rclpy.try_shutdown()
        sys.exit(code)
