"""``battery_doctor`` (ROS 2): what a live graph of batteries and their consumers gets wrong.

    ros2 run battery_simulator battery_doctor [--wait S] [--sample S] [--ros-args ...]

Waits ``--wait`` seconds (default 5) for discovery, lists every battery publisher and every
subscriber of a battery or velocity topic with its type and QoS (reliability, durability, depth
where discovery tells it), samples each battery topic for up to ``--sample`` seconds (default 3)
with a QoS each publisher matches, then prints one line per finding (core/doctor.py's rules).
Exit 0 when clean, 1 when it found something, 2 for a bad command line or an empty graph.
"""
import sys
import time

from battery_simulator.core import doctor

STEP_S = 0.05
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
    return doctor.Endpoint(node, info.topic_type, reliability, durability, qos.depth or None)


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


def _sampling_qos(publisher):
    """A subscription QoS this publisher matches: its own reliability and durability."""
    from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
    return QoSProfile(
        history=HistoryPolicy.KEEP_LAST, depth=10,
        reliability=(ReliabilityPolicy.BEST_EFFORT if publisher.reliability == doctor.BEST_EFFORT
                     else ReliabilityPolicy.RELIABLE),
        durability=(DurabilityPolicy.TRANSIENT_LOCAL if publisher.durability == doctor.TRANSIENT_LOCAL
                    else DurabilityPolicy.VOLATILE))


def sample(node, graph, seconds):
    """Add up to doctor.SAMPLES_PER_TOPIC BatteryState samples to each published battery topic,
    waiting at most ``seconds``."""
    import rclpy
    from sensor_msgs.msg import BatteryState

    def _record(topic, msg):
        topic.samples.append(doctor.Sample(float(msg.percentage), float(msg.current), int(msg.power_supply_status)))

    subscriptions = []
    wanted = []
    for name, topic in sorted(graph.topics.items()):
        publishers = [e for e in topic.publishers if doctor.is_battery_type(e.type)]
        kinds = sorted({(e.reliability, e.durability) for e in publishers})
        for reliability, durability in kinds:
            qos = _sampling_qos(doctor.Endpoint('', '', reliability, durability))
            subscriptions.append(node.create_subscription(
                BatteryState, name, lambda msg, topic=topic: _record(topic, msg), qos))
        if kinds:
            wanted.append(topic)
    deadline = time.monotonic() + seconds
    while wanted and time.monotonic() < deadline:
        rclpy.spin_once(node, timeout_sec=STEP_S)
        if all(len(topic.samples) >= doctor.SAMPLES_PER_TOPIC for topic in wanted):
            break
    for subscription in subscriptions:
        node.destroy_subscription(subscription)


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
        deadline = time.monotonic() + options['wait']
        while time.monotonic() < deadline:
            rclpy.spin_once(node, timeout_sec=STEP_S)
        if not _other_nodes(node):
            print('battery_doctor: no other node on the ROS 2 graph (ROS_DOMAIN_ID=%s) within %g s: start the '
                  'robot first, or give a longer --wait' % (os.environ.get('ROS_DOMAIN_ID', '0'), options['wait']),
                  file=sys.stderr)
            return
        graph = describe(node)
        sample(node, graph, options['sample'])
        lines, code = doctor.report(graph)
        print('\n'.join(lines), flush=True)
    except KeyboardInterrupt:
        code = 130
    finally:
        rclpy.try_shutdown()
        sys.exit(code)
