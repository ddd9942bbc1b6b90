"""``battery_doctor`` (ROS 2): what a live graph of batteries and their consumers gets wrong.

    ros2 run battery_simulator battery_doctor [--wait S] [--sample S] [--ros-args ...]

Discovers the graph for ``--wait`` seconds (default 5), and samples meanwhile: each battery topic is
subscribed as soon as discovery shows it (one best-effort volatile subscription, which every publisher
matches; each message credited to its publisher's GID). It then lists every battery publisher and every
subscriber of a battery or velocity topic with its type and QoS (reliability, durability, depth where
discovery tells it) and hears each battery topic out: 3 messages and one from each publisher, or
``--sample`` seconds (default 3) of silence from a publisher once it is matched and its process has
stopped catching up with the new subscriptions (a busy host of 100 robots takes seconds over 200). Then
one line per finding (core/doctor.py's rules) and an ``unsampled:`` line for the topics it could not hear
out. Exit 0 when clean and every battery topic sampled, 1 when it found something or left a topic
unsampled, 2 for a bad command line or an empty graph. 100 robots (battery_fleet): 8-10 s at a load
average of 9-10 on 2 cores, 12-17 s at 22-25 (tools/benchmark_dashboard.py --doctor-only 100).
"""
import sys
import time

from battery_simulator.core import doctor

STEP_S = 0.05
#: how long past ``--sample`` the doctor waits for its subscriptions to be matched to every publisher
#: (discovery of 200 new subscriptions on a busy machine takes seconds)
MATCH_ALLOWANCE_S = 5.0
#: discovery is over when it found nothing new (no topic, no battery publisher) for this long: on 2 busy cores
#: a new participant had found 24-192 of a 100-robot host's 200 battery topics at the end of the 5 s wait, and
#: what a full socket buffer dropped came again seconds later (at a reliable writer's heartbeat)
DISCOVERY_QUIET_S = 2.0
#: the battery topics discovery shows are subscribed from this far in, and again every period
FIRST_LOOK_S = 0.25
LOOK_PERIOD_S = 0.25
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


def participant(gid):
    """The process (DDS participant) of an endpoint: its GID's first 12 bytes (the GUID prefix), in hex."""
    return gid[:24] if gid else None


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
        self.heard = set()   # the GIDs of the publishers that sent a sample
        self.progress = {}   # participant (GID prefix) -> monotonic time one of its publishers was first heard
        self._found = None   # what the last scan found: the topic count, each battery topic's publisher count

    def _record(self, samples, msg, info):
        gid = gid_text(info.get('publisher_gid'))
        samples.append(doctor.Sample(float(msg.percentage), float(msg.current), int(msg.power_supply_status),
                                     float(msg.voltage), gid))
        if gid not in self.heard:
            self.heard.add(gid)
            self.progress[participant(gid)] = time.monotonic()

    def _subscribe(self, name, publishers):
        from sensor_msgs.msg import BatteryState
        samples = []
        subscription = self.node.create_subscription(
            BatteryState, name, lambda msg, info, samples=samples: self._record(samples, msg, info), _sampling_qos())
        self.records[name] = {'samples': samples, 'subscription': subscription, 'publishers': publishers,
                              'since': None}

    def scan(self):
        """Subscribe to every battery topic discovery shows now and not subscribed yet: from the topic names
        and types alone (describing 300 topics' endpoints takes a busy machine most of a second). True when
        discovery found more since the last scan (a topic, or a battery topic's publisher)."""
        topics = self.node.get_topic_names_and_types()
        found = [len(topics)]
        for name, types in topics:
            if any(doctor.is_battery_type(t) for t in types):
                publishers = self.node.count_publishers(name)
                found.append(publishers)
                if name not in self.records and publishers:
                    self._subscribe(name, publishers)
        grew, self._found = found != self._found, found
        return grew

    def subscribe(self, graph):
        """Subscribe to every published battery topic of ``graph`` not subscribed yet; the others learn how
        many battery publishers they have."""
        for name, topic in sorted(graph.topics.items()):
            publishers = len({e.key for e in topic.battery_publishers()})
            if not publishers:
                continue
            if name in self.records:
                self.records[name]['publishers'] = publishers
            else:
                self._subscribe(name, publishers)

    def track(self, now):
        """Note when each subscription is matched to every publisher its topic has."""
        for record in self.records.values():
            if record['since'] is None and record['subscription'].get_publisher_count() >= record['publishers']:
                record['since'] = now

    def attach(self, graph, seconds):
        """Give ``graph``'s published battery topics their samples (subscribing to any not subscribed yet):
        {name: Topic} of them, each to be heard out for ``seconds``."""
        self.subscribe(graph)
        topics = {}
        for name, topic in graph.topics.items():
            if name in self.records and topic.battery_publishers():
                topic.sampled_s = seconds
                topic.samples = self.records[name]['samples']
                topics[name] = topic
        return topics

    def heard_out(self, name, topic, now, waiting):
        """Whether ``topic`` is done: each publisher sent a message and it has doctor.SAMPLES_PER_TOPIC, or its
        silent publishers were heard for the window of ``topic.sampled_s`` (``Topic.heard``: how long so far).

        A subscription matched here is matched in the publisher's process only once that process has worked
        through it: a host of 100 robots on a busy machine takes seconds over 200 new subscriptions (they
        were said "sent nothing" while it was still at it). So a publisher not heard yet is waited for while
        its process (its GID's participant prefix) has other publishers not heard yet (``waiting``: {process:
        publishers not heard}), and its window starts when it was matched here and its process was last
        heard from on a publisher for the first time."""
        since = self.records[name]['since']
        unheard = doctor.unheard(topic)
        if len(topic.samples) >= doctor.SAMPLES_PER_TOPIC and not unheard:
            return True
        if since is None:
            return False
        processes = [participant(e.gid) for e in unheard if e.gid]
        if any(waiting.get(p, 0) > processes.count(p) for p in processes):
            return False   # its process is still catching up
        start = max([since] + [self.progress.get(p, since) for p in processes])
        topic.heard = now - start
        return now - start >= topic.sampled_s

    def run(self, wait_s, seconds):
        """Discover and sample at once. The battery topics discovery shows are subscribed from FIRST_LOOK_S on
        and again every LOOK_PERIOD_S (a busy host needs seconds to match 200 new subscriptions before it
        sends to them) and heard out while discovery goes on. From ``wait_s`` on, the graph to report is
        described (again whenever discovery found more since), and the run ends once discovery has found
        nothing new for DISCOVERY_QUIET_S and each battery topic is heard out (``heard_out``); at the latest
        ``seconds`` + max(``seconds``, MATCH_ALLOWANCE_S) after ``wait_s``, with the topics not heard out
        (unsampled) and, if discovery was still finding endpoints, ``Graph.discovering_s`` set. The graph.

        Before, sampling began only after the whole discovery wait, and the graph was what discovery had
        found by then: on 100 robots and a busy machine 8-20 s end to end, as few as 98 of 200 battery
        topics found and "no problems found" said (issue 40 item 4)."""
        import rclpy
        started = time.monotonic()
        wait_deadline = started + wait_s
        hard_deadline = wait_deadline + seconds + max(seconds, MATCH_ALLOWANCE_S)
        next_look = started + FIRST_LOOK_S
        grew_at, described_at = started, None
        graph, pending = None, {}
        while True:
            rclpy.spin_once(self.node, timeout_sec=STEP_S)
            now = time.monotonic()
            self.track(now)
            if now >= next_look:
                if self.scan():
                    grew_at = now
                next_look = now + LOOK_PERIOD_S
            if now < wait_deadline:
                continue
            if described_at is None or described_at < grew_at:   # the graph to report, every topic in it sampled
                graph = describe(self.node)
                pending = self.attach(graph, seconds)
                described_at = now
            waiting = {}
            for topic in pending.values():
                for endpoint in doctor.unheard(topic):
                    waiting[participant(endpoint.gid)] = waiting.get(participant(endpoint.gid), 0) + 1
            for name, topic in list(pending.items()):
                if now >= hard_deadline:   # those still waited for are unsampled, not silent (core/doctor.py)
                    if not self.heard_out(name, topic, now, waiting):
                        topic.heard = None
                    del pending[name]
                elif self.heard_out(name, topic, now, waiting):
                    del pending[name]
            settled = now - grew_at >= DISCOVERY_QUIET_S
            if (not pending and settled) or now >= hard_deadline:
                if not settled:
                    graph.discovering_s = now - started
                return graph

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
        graph = sampler.run(options['wait'], options['sample'])
        if not _other_nodes(node):
            print('battery_doctor: no other node on the ROS 2 graph (ROS_DOMAIN_ID=%s) within %g s: start the '
                  'robot first, or give a longer --wait' % (os.environ.get('ROS_DOMAIN_ID', '0'), options['wait']),
                  file=sys.stderr)
            return
        sampler.close()
        lines, code = doctor.report(graph)
        print('\n'.join(lines), flush=True)
    except KeyboardInterrupt:
        code = 130
    finally:
        rclpy.try_shutdown()
        sys.exit(code)
