"""``battery_doctor.py`` (ROS 1): what a live graph of batteries and their consumers gets wrong.

    rosrun battery_simulator battery_doctor.py [--wait S] [--sample S]

Asks the master (getSystemState, getTopicTypes) for every battery or velocity topic, and each node
on them (its slave API: getPublications / getSubscriptions, with a bound of ``--wait`` seconds,
default 2) for the type it really uses (the master keeps one type a topic), samples each battery
topic for ``--sample`` seconds (default 3) from the moment it is connected to every publisher (each
message credited to the node that sent it; the subscribers made 16 at a time, each a call to the master;
a node not heard on a topic is waited for while it has other topics not heard yet: a busy fleet host serves
200 new connections for seconds), then prints core/doctor.py's report. ROS 1 has no QoS. 100 robots
(fleet.launch n:=100) at a load average of 21 on 2 cores: 14.5-16.3 s, all 200 sampled (before: 17.8-18.2
s, 21-56 unsampled).
Exit 0 when clean and every battery topic sampled, 1 when it found something or left a topic
unsampled, 2 for a bad command line or no ROS master.
"""
import sys
import time
import xmlrpc.client
from concurrent.futures import ThreadPoolExecutor

from battery_simulator.core import doctor

CALLER_ID = '/battery_doctor'
STEP_S = 0.05
#: how long past ``--sample`` the doctor waits for its subscribers to connect to every publisher
MATCH_ALLOWANCE_S = 5.0
#: subscribers made at once (each registers with the master)
SUBSCRIBE_THREADS = 16


class _TimeoutTransport(xmlrpc.client.Transport):
    """An XML-RPC transport whose connections give up after ``timeout_s``."""

    def __init__(self, timeout_s):
        super().__init__()
        self._timeout_s = timeout_s

    def make_connection(self, host):
        connection = super().make_connection(host)
        connection.timeout = self._timeout_s
        return connection


def _node_types(master, node, timeout_s):
    """({topic: type} published, {topic: type} subscribed) by ``node``, from its own API; ({}, {}) if it
    does not answer in time."""
    try:
        uri = master.lookupNode(node)
        proxy = xmlrpc.client.ServerProxy(uri, transport=_TimeoutTransport(timeout_s))
        code_p, _, published = proxy.getPublications(CALLER_ID)
        code_s, _, subscribed = proxy.getSubscriptions(CALLER_ID)
    except Exception:   # a node gone or hung: the master's type stands in
        return {}, {}
    return (dict(published) if code_p == 1 else {}), (dict(subscribed) if code_s == 1 else {})


def describe(master, timeout_s):
    """The graph as the master and the nodes tell it: every battery or velocity topic."""
    publishers, subscribers, _ = master.getSystemState()
    master_types = dict(master.getTopicTypes())
    cache = {}

    def types_of(node):
        if node not in cache:
            cache[node] = _node_types(master, node, timeout_s)
        return cache[node]

    graph = doctor.Graph(has_qos=False)
    listed = {}
    for name, nodes in publishers:
        listed.setdefault(name, ([], []))[0].extend(nodes)
    for name, nodes in subscribers:
        listed.setdefault(name, ([], []))[1].extend(nodes)
    for name, (pub_nodes, sub_nodes) in sorted(listed.items()):
        fallback = master_types.get(name, '*')
        if not doctor.topic_of_interest(name, [fallback]):
            # a topic the master types otherwise may still be one a node takes as BatteryState or Twist
            node_types = [types_of(n)[0].get(name) for n in pub_nodes] + [types_of(n)[1].get(name) for n in sub_nodes]
            if not doctor.topic_of_interest(name, [t for t in node_types if t]):
                continue
        topic = graph.topic(name)
        topic.publishers += [doctor.Endpoint(n, types_of(n)[0].get(name, fallback)) for n in sorted(set(pub_nodes))]
        topic.subscribers += [doctor.Endpoint(n, types_of(n)[1].get(name, fallback)) for n in sorted(set(sub_nodes))]
    return graph


def sample(graph, seconds):
    """Sample every published battery topic: one subscriber each, every message credited to the node that
    sent it (its connection's callerid: ROS 1 has one publisher a node and topic). A topic is done when each
    publisher sent a message and it has doctor.SAMPLES_PER_TOPIC; the window of ``seconds`` starts for a
    topic when the subscriber is connected to every publisher (``Topic.heard``: how long it was, at the
    end). Ends when every topic is done or heard out, and at the latest ``seconds`` + MATCH_ALLOWANCE_S
    after the subscribers were made (a publisher that does not answer its connection is never heard)."""
    import rospy
    from sensor_msgs.msg import BatteryState

    progress = {}   # node -> monotonic time one of its topics was first heard

    def _record(msg, topic):
        sender = getattr(msg, '_connection_header', {}).get('callerid')
        if sender not in {sample.publisher for sample in topic.samples}:
            progress[sender] = time.monotonic()
        topic.samples.append(doctor.Sample(float(msg.percentage), float(msg.current), int(msg.power_supply_status),
                                           float(msg.voltage), sender))

    published = [(name, topic) for name, topic in sorted(graph.topics.items()) if topic.battery_publishers()]

    def subscribe(item):
        name, topic = item
        topic.sampled_s = seconds
        subscriber = rospy.Subscriber(name, BatteryState, _record, callback_args=topic, queue_size=10)
        return name, [topic, subscriber, len({e.key for e in topic.battery_publishers()}), None]
    # each subscriber is a call to the master (registerSubscriber): made one by one, 200 took 5.5 s on a busy
    # machine, and the last ones had too little of the window to connect (56 of 200 unsampled at 100 robots)
    with ThreadPoolExecutor(max_workers=SUBSCRIBE_THREADS) as pool:
        pending = dict(pool.map(subscribe, published))   # name -> [topic, subscriber, publishers, connected since]
    subscribers = [entry[1] for entry in pending.values()]
    hard_deadline = time.monotonic() + seconds + max(seconds, MATCH_ALLOWANCE_S)
    while pending and not rospy.is_shutdown():
        time.sleep(STEP_S)
        now = time.monotonic()
        waiting = {}   # node -> its publishers not heard yet
        for topic, _, _, _ in pending.values():
            for endpoint in doctor.unheard(topic):
                waiting[endpoint.key] = waiting.get(endpoint.key, 0) + 1
        for name, entry in list(pending.items()):
            topic, subscriber, publishers, since = entry
            if since is None and subscriber.get_num_connections() >= publishers:
                entry[3] = since = now
            if _heard_out(topic, since, now, waiting, progress):
                del pending[name]
            elif now >= hard_deadline:   # still waited for: unsampled, not silent
                topic.heard = None if since is None or _catching_up(topic, waiting) else min(topic.heard, seconds)
                del pending[name]
    with ThreadPoolExecutor(max_workers=SUBSCRIBE_THREADS) as pool:   # each a call to the master too
        list(pool.map(lambda subscriber: subscriber.unregister(), subscribers))


def _catching_up(topic, waiting):
    """Whether a node that has not sent on ``topic`` yet has other topics not heard yet (``waiting``: {node:
    topics not heard}): a fleet host of 100 robots on a busy machine serves 200 new connections for seconds
    after they were made, so its silence on one of them says nothing yet."""
    keys = [e.key for e in doctor.unheard(topic)]
    return any(waiting.get(key, 0) > keys.count(key) for key in keys)


def _heard_out(topic, since, now, waiting, progress):
    """Whether ``topic`` is done: each publisher sent a message and it has doctor.SAMPLES_PER_TOPIC, or its
    silent publishers were heard for the window of ``topic.sampled_s`` (``Topic.heard``) from when it was
    connected and their node last sent on a topic for the first time, and their node is not still catching up."""
    unheard = doctor.unheard(topic)
    if len(topic.samples) >= doctor.SAMPLES_PER_TOPIC and not unheard:
        return True
    if since is None or _catching_up(topic, waiting):
        return False
    start = max([since] + [progress.get(e.key, since) for e in unheard])
    topic.heard = now - start
    return now - start >= topic.sampled_s


def main(argv=None):
    import rosgraph
    import rospy
    argv = rospy.myargv(sys.argv)[1:] if argv is None else argv
    try:
        options = doctor.parse_arguments(argv, 'battery_doctor.py')
    except doctor.UsageError as error:
        print(error, file=sys.stderr)
        sys.exit(doctor.EXIT_USAGE)
    master = rosgraph.Master(CALLER_ID)
    try:
        master.getPid()
    except Exception:
        print('battery_doctor.py: no ROS master at %s: start roscore, or set ROS_MASTER_URI'
              % rosgraph.get_master_uri(), file=sys.stderr)
        sys.exit(doctor.EXIT_USAGE)
    code = doctor.EXIT_USAGE
    try:
        graph = describe(master, options['wait'])
        rospy.init_node('battery_doctor', anonymous=True, disable_signals=True, disable_rosout=True)
        sample(graph, options['sample'])
        lines, code = doctor.report(graph)
        print('\n'.join(lines), flush=True)
    except KeyboardInterrupt:
        code = 130
    finally:
        if rospy.core.is_initialized():
            rospy.signal_shutdown('battery_doctor done')
    sys.exit(code)
