"""What ``battery_doctor`` finds wrong in a graph of batteries and their consumers (ROS-free).

The ROS 1 and ROS 2 adapters (``ros1/doctor.py``, ``ros2/doctor.py``) describe the live graph as a
:class:`Graph`: every topic of interest with its publishers and subscribers (node, type, and on
ROS 2 the QoS reliability, durability and depth) and a few sampled ``sensor_msgs/BatteryState``
values per battery topic. :func:`listing` says what is there, :func:`findings` what is wrong, one
line each beginning ``problem:``, naming the topic and the fix:

- a battery topic subscribed that nobody publishes (a docking server on ``/robot1/battery_state``
  while the battery publishes ``/robot1/battery_status``): the remap, or the battery's parameter;
- a type mismatch (a ``TwistStamped`` publisher and a ``Twist``-only subscriber, or the reverse);
- a QoS that cannot match (a reliable subscriber and a best-effort publisher; a transient-local
  subscriber and a volatile publisher);
- a percentage above 1 (a 0-100 publisher);
- a current whose sign contradicts ``power_supply_status`` (charging with a negative current);
- two publishers of one battery topic, counted by endpoint (ROS 2: its GID; ROS 1: its node, the master
  keeps one publisher a node and topic), so three publishers that share a node name are three;
- a voltage or percentage out of its range (a NaN or negative voltage, a percentage below 0);
- a publisher that went silent: the sampler was connected to it for the whole sampling window and it
  sent nothing.

A battery topic the sampler could not hear (not connected to every publisher in time) is listed on an
``unsampled:`` line of its own and counts as a finding (exit 1), and so does a discovery still finding
endpoints when the doctor had to stop (an ``undiscovered:`` line): the doctor never says "no problems
found" about what it did not see.
"""
import math
from dataclasses import dataclass, field

BATTERY_TYPE = 'sensor_msgs/BatteryState'
TWIST = 'geometry_msgs/Twist'
TWIST_STAMPED = 'geometry_msgs/TwistStamped'
VELOCITY_TYPES = (TWIST, TWIST_STAMPED)
#: the type a ROS 1 node reports for a rospy.AnyMsg subscription (the battery's cmd_vel): it takes any type
ANY_TYPE = '*'
#: last name parts that make a topic a battery or velocity topic whatever its type
BATTERY_NAMES = ('battery_status', 'battery_state', 'battery')
VELOCITY_NAMES = ('cmd_vel',)

RELIABLE, BEST_EFFORT = 'reliable', 'best_effort'
VOLATILE, TRANSIENT_LOCAL = 'volatile', 'transient_local'

#: sensor_msgs/BatteryState.power_supply_status (the same numbers on ROS 1 and ROS 2)
CHARGING, DISCHARGING = 1, 2
STATUS_NAMES = {0: 'UNKNOWN', 1: 'CHARGING', 2: 'DISCHARGING', 3: 'NOT_CHARGING', 4: 'FULL'}
#: a current this close to 0 A contradicts no status (sensor noise at rest)
SIGN_TOLERANCE_A = 0.05
#: how the battery is asked for Nav2's topic name (the parameter the battery's front ends take)
BATTERY_STATE_FIX = ('or have the battery publish that name too (battery_state_pub\'s battery_state_topic parameter, '
                     'docs/consumers.md)')

EXIT_CLEAN, EXIT_FOUND, EXIT_USAGE = 0, 1, 2


@dataclass(frozen=True)
class Endpoint:
    """One publisher or subscription on a topic; the QoS fields are None where ROS has none. ``gid``: the
    endpoint's own id (ROS 2's GID, hex) where ROS has one; else the node is the endpoint."""
    node: str
    type: str
    reliability: str = None
    durability: str = None
    depth: int = None
    gid: str = None

    @property
    def key(self):
        """What tells this endpoint from every other on its topic."""
        return self.gid if self.gid else self.node


@dataclass(frozen=True)
class Sample:
    """What one BatteryState message said (NaN where it said nothing; voltage None: not read); ``publisher``:
    the key of the endpoint that sent it (None where the sampler cannot tell)."""
    percentage: float = math.nan
    current: float = math.nan
    power_supply_status: int = 0
    voltage: float = None
    publisher: str = None


@dataclass
class Topic:
    """``heard``: for a sampled battery topic, the seconds the sampler was connected to every publisher of
    it (None: never to all of them; not set: not sampled at all). ``sampled_s``: the window it asked for."""
    publishers: list = field(default_factory=list)
    subscribers: list = field(default_factory=list)
    samples: list = field(default_factory=list)
    heard: float = None
    sampled_s: float = None

    def battery_publishers(self):
        return [e for e in self.publishers if is_battery_type(e.type)]


@dataclass
class Graph:
    """{topic name: Topic}; ``has_qos`` is False on ROS 1; ``discovering_s``: set when discovery was still
    finding endpoints after that many seconds, when the doctor had to stop (the graph may be larger)."""
    topics: dict = field(default_factory=dict)
    has_qos: bool = True
    discovering_s: float = None

    def topic(self, name):
        return self.topics.setdefault(name, Topic())


def plain_type(type_name):
    """'sensor_msgs/msg/BatteryState' (ROS 2) -> 'sensor_msgs/BatteryState' (ROS 1's spelling)."""
    return type_name.replace('/msg/', '/')


def is_battery_type(type_name):
    return plain_type(type_name) == BATTERY_TYPE


def is_velocity_type(type_name):
    return plain_type(type_name) in VELOCITY_TYPES


def topic_of_interest(name, types):
    """A battery or velocity topic: by one of its types, or by its name's last part."""
    last = name.rstrip('/').rsplit('/', 1)[-1]
    return (any(is_battery_type(t) or is_velocity_type(t) for t in types)
            or last in BATTERY_NAMES or last in VELOCITY_NAMES)


def namespace_of(name):
    """'/robot1/battery_state' -> '/robot1'; '/battery_status' -> '/'."""
    head = name.rstrip('/').rsplit('/', 1)[0]
    return head or '/'


def _qos(endpoint):
    if endpoint.reliability is None:
        return ''
    depth = '' if endpoint.depth is None else ', depth %d' % endpoint.depth
    return ' (%s, %s%s)' % (endpoint.reliability, endpoint.durability, depth)


def _battery_topics(graph):
    return sorted(name for name, topic in graph.topics.items()
                  if any(is_battery_type(e.type) for e in topic.publishers + topic.subscribers))


def listing(graph):
    """The lines that show the graph: every battery publisher, every subscriber of a battery or
    velocity topic, and the velocity publishers (whose type a subscriber must take)."""
    lines = []
    qos_note = '' if graph.has_qos else ' (ROS 1: no QoS)'
    for name in sorted(graph.topics):
        topic = graph.topics[name]
        battery = any(is_battery_type(e.type) for e in topic.publishers + topic.subscribers)
        for endpoint in sorted(topic.publishers, key=lambda e: e.node):
            lines.append('publisher   %s  %s  %s%s' % (name, endpoint.type, endpoint.node, _qos(endpoint)))
        for endpoint in sorted(topic.subscribers, key=lambda e: e.node):
            lines.append('subscriber  %s  %s  %s%s' % (name, endpoint.type, endpoint.node, _qos(endpoint)))
        if battery and topic.samples:
            last = topic.samples[-1]
            lines.append('sampled     %s  %d message(s), last: percentage %s, current %s A, %s' % (
                name, len(topic.samples), _number(last.percentage), _number(last.current),
                STATUS_NAMES.get(last.power_supply_status, str(last.power_supply_status))))
    if not lines:
        lines.append('no battery or velocity topic on the graph%s' % qos_note)
    elif qos_note:
        lines.append('QoS%s' % qos_note)
    return lines


def _number(value):
    return 'NaN' if math.isnan(value) else '%.3g' % value


def findings(graph):
    """One line per problem, each beginning 'problem:', naming the topic and the fix; [] when clean."""
    found = []
    for name in sorted(graph.topics):
        topic = graph.topics[name]
        found += _unpublished_battery(graph, name, topic)
        found += _type_mismatches(name, topic)
        if graph.has_qos:
            found += _qos_mismatches(name, topic)
        found += _two_batteries(name, topic)
        found += _percentage_scale(name, topic)
        found += _out_of_range(name, topic)
        found += _current_sign(name, topic)
        found += _silent_publishers(name, topic)
    return found


def unsampled(graph):
    """The published battery topics the sampler did not hear out: not connected to every publisher for the
    window it asked for ({name: why})."""
    missed = {}
    for name in sorted(graph.topics):
        topic = graph.topics[name]
        if not topic.battery_publishers() or topic.sampled_s is None or not unheard(topic):
            continue   # every publisher heard from
        if topic.heard is None:
            missed[name] = 'not connected to every publisher'
        elif topic.heard < topic.sampled_s:
            missed[name] = 'connected for %.1f s of %.1f' % (topic.heard, topic.sampled_s)
    return missed


def not_sampled_at_all(graph):
    """Published battery topics the sampler never tried (sampled_s unset)."""
    return sorted(name for name, topic in graph.topics.items()
                  if topic.battery_publishers() and topic.sampled_s is None)


def unheard(topic):
    """The battery publishers of ``topic`` that sent no sample."""
    heard = {sample.publisher for sample in topic.samples}
    if None in heard:   # the sampler cannot tell publishers apart: the topic spoke
        return [] if topic.samples else topic.battery_publishers()
    return [e for e in topic.battery_publishers() if e.key not in heard]


def _nodes(endpoints):
    return ', '.join(sorted({e.node for e in endpoints}))


def _unpublished_battery(graph, name, topic):
    readers = [e for e in topic.subscribers if is_battery_type(e.type)]
    if not readers or topic.publishers:
        return []
    published = [other for other in _battery_topics(graph)
                 if any(is_battery_type(e.type) for e in graph.topics[other].publishers)]
    here = [other for other in published if namespace_of(other) == namespace_of(name)]
    candidates = here or published
    who = _nodes(readers)
    if not candidates:
        return ['problem: %s: subscribed by %s, published by nobody, and no battery publishes on the graph: '
                'start the battery (battery_sim with __ns:=%s)' % (name, who, namespace_of(name))]
    if len(candidates) == 1:
        target = candidates[0]
        fix = 'remap %s:=%s for %s, %s' % (name, target, who, BATTERY_STATE_FIX)
        return ['problem: %s: subscribed by %s, published by nobody; the battery publishes %s: %s'
                % (name, who, target, fix)]
    return ['problem: %s: subscribed by %s, published by nobody; batteries publish %s: remap %s:=<one of them> '
            'for %s, %s' % (name, who, ', '.join(candidates), name, who, BATTERY_STATE_FIX)]


def _type_mismatches(name, topic):
    """A publisher whose type a subscribing node does not take: nothing of it arrives there."""
    found = []
    taken = {}
    for endpoint in topic.subscribers:
        taken.setdefault(endpoint.node, set()).add(plain_type(endpoint.type))
    for publisher in sorted(topic.publishers, key=lambda e: e.node):
        sent = plain_type(publisher.type)
        for node in sorted(taken):
            if sent in taken[node] or ANY_TYPE in taken[node]:
                continue
            found.append('problem: %s: %s publishes %s, %s subscribes %s only (nothing of it arrives): %s'
                         % (name, publisher.node, sent, node, ' and '.join(sorted(taken[node])),
                            _type_fix(sent, taken[node])))
    return found


def _type_fix(sent, taken):
    if sent == TWIST_STAMPED and TWIST in taken:
        return ('set enable_stamped_cmd_vel: false on Nav2\'s controller_server, velocity_smoother and '
                'docking_server, or have the subscriber take geometry_msgs/TwistStamped')
    if sent == TWIST and TWIST_STAMPED in taken:
        return ('set enable_stamped_cmd_vel: true on Nav2\'s controller_server, velocity_smoother and '
                'docking_server (Kilted\'s default), or have the subscriber take geometry_msgs/Twist')
    return 'publish and subscribe one type on this topic'


def _qos_mismatches(name, topic):
    found = []
    for subscriber in sorted(topic.subscribers, key=lambda e: e.node):
        for publisher in sorted(topic.publishers, key=lambda e: e.node):
            if plain_type(publisher.type) != plain_type(subscriber.type):
                continue   # already a type mismatch
            if subscriber.reliability == RELIABLE and publisher.reliability == BEST_EFFORT:
                found.append('problem: %s: QoS cannot match: %s subscribes reliable, %s publishes best_effort '
                             '(nothing arrives): make the subscription best_effort or the publisher reliable'
                             % (name, subscriber.node, publisher.node))
            if subscriber.durability == TRANSIENT_LOCAL and publisher.durability == VOLATILE:
                found.append('problem: %s: QoS cannot match: %s subscribes transient_local, %s publishes volatile '
                             '(nothing arrives): make the subscription volatile or the publisher transient_local'
                             % (name, subscriber.node, publisher.node))
    return found


def _who(endpoints):
    """'/r6/a, /r6/b' or '/r8/battery_state_pub (3 publishers)': each node once, with its count."""
    counts = {}
    for endpoint in endpoints:
        counts[endpoint.node] = counts.get(endpoint.node, 0) + 1
    return ', '.join(node if count == 1 else '%s (%d publishers)' % (node, count)
                     for node, count in sorted(counts.items()))


def _two_batteries(name, topic):
    """Counted by endpoint: three publishers in one process may share one node name (a fleet host whose
    robots all landed in one namespace; a driver started three times with one name)."""
    publishers = {e.key: e for e in topic.battery_publishers()}
    if len(publishers) < 2:
        return []
    return ['problem: %s: %d publishers publish this battery (%s): a reader sees their readings interleaved; '
            'give each battery its own namespace (__ns:=/robotN) or stop all but one'
            % (name, len(publishers), _who(publishers.values()))]


def _out_of_range(name, topic):
    """A NaN, infinite or negative voltage (BatteryState's voltage is mandatory), a percentage below 0 (NaN
    is allowed: unmeasured; above 1 is _percentage_scale's)."""
    found = []
    voltages = [s.voltage for s in topic.samples
                if s.voltage is not None and not (math.isfinite(s.voltage) and s.voltage >= 0.0)]
    if voltages:
        found.append('problem: %s: voltage %s is out of its range (sensor_msgs/BatteryState.voltage is mandatory, '
                     'in volts, >= 0): publish the measured pack voltage (Nav2 and Open-RMF read it)%s'
                     % (name, _number(voltages[0]), _by(topic, lambda s: s.voltage in voltages)))
    below = [s.percentage for s in topic.samples if s.percentage < 0.0]
    if below:
        found.append('problem: %s: percentage %s is below 0: sensor_msgs/BatteryState.percentage is 0-1, NaN when '
                     'unmeasured (Nav2\'s IsBatteryLow reads a negative level as empty): publish NaN, not a '
                     'negative sentinel%s' % (name, _number(min(below)), _by(topic, lambda s: s.percentage < 0.0)))
    return found


def _by(topic, wrong):
    """' (from /node)' naming who sent the samples ``wrong`` picks, where the sampler can tell."""
    keys = {s.publisher for s in topic.samples if wrong(s)}
    senders = [e for e in topic.battery_publishers() if e.key in keys]
    return ' (from %s)' % _who(senders) if senders and len(topic.battery_publishers()) > 1 else ''


def _silent_publishers(name, topic):
    """A publisher the sampler was connected to for its whole window that sent nothing."""
    if topic.heard is None or topic.sampled_s is None or topic.heard < topic.sampled_s:
        return []
    silent = unheard(topic)
    if not silent:
        return []
    return ['problem: %s: %s sent nothing in %.1f s of sampling (connected): it went silent (a hung driver, a '
            'stopped timer), publishes slower than that, or has not matched this doctor yet (a host busy with '
            'discovery): restart it, or give a longer --sample'
            % (name, _who(silent) if len(topic.battery_publishers()) > 1 or silent[0].gid is None
               else silent[0].node, topic.heard)]


def _percentage_scale(name, topic):
    above = [s.percentage for s in topic.samples if not math.isnan(s.percentage) and s.percentage > 1.0]
    if not above:
        return []
    return ['problem: %s: percentage %s is above 1 (a 0-100 scale): sensor_msgs/BatteryState.percentage is '
            '0-1 (Nav2\'s IsBatteryLow and Open-RMF read it so): divide by 100 in the publisher (ros2_control\'s '
            'battery_state_broadcaster computes 0-100 from voltage; Gazebo\'s fix_issue_225 too)'
            % (name, _number(max(above)))]


def _current_sign(name, topic):
    for sample in topic.samples:
        if math.isnan(sample.current):
            continue
        if sample.power_supply_status == CHARGING and sample.current < -SIGN_TOLERANCE_A:
            sign = 'negative'
        elif sample.power_supply_status == DISCHARGING and sample.current > SIGN_TOLERANCE_A:
            sign = 'positive'
        else:
            continue
        return ['problem: %s: current %.3g A is %s while power_supply_status is %s: BatteryState\'s current is '
                'positive while charging and negative while discharging (opennav_docking\'s SimpleChargingDock '
                'reads current > 0.5 A as charging): invert the driver\'s sign (Gazebo: invert_current_sign)'
                % (name, sample.current, sign, STATUS_NAMES[sample.power_supply_status])]
    return []


def report(graph):
    """(lines to print, exit status): the listing, the findings, the battery topics not heard out on one
    ``unsampled:`` line (each counts as a finding), then a summary line."""
    problems = findings(graph)
    missed = unsampled(graph)
    never = not_sampled_at_all(graph)
    lines = listing(graph) + problems
    if missed or never:
        why = ['%s (%s)' % (name, reason) for name, reason in missed.items()] + \
              ['%s (not sampled)' % name for name in never]
        lines.append('unsampled: %d battery topic(s) not heard out, so not checked: %s: give a longer --sample '
                     '(or --wait)' % (len(why), ', '.join(why)))
    if graph.discovering_s is not None:
        lines.append('undiscovered: discovery was still finding endpoints after %.1f s, so the graph may be larger '
                     'than shown: give a longer --wait' % graph.discovering_s)
    count = len(problems) + len(missed) + len(never) + (graph.discovering_s is not None)
    if not count:
        return lines + ['no problems found'], EXIT_CLEAN
    summary = '%d problem(s) found' % len(problems)
    if missed or never:
        summary += ', %d battery topic(s) unsampled' % (len(missed) + len(never))
    if graph.discovering_s is not None:
        summary += ', discovery unfinished'
    return lines + [summary], EXIT_FOUND


#: the bounds of --wait and --sample (seconds)
MAX_WAIT_S = 60.0
#: BatteryState messages sampled per battery topic (fewer if --sample ends first)
SAMPLES_PER_TOPIC = 3


class UsageError(ValueError):
    """A bad command line; the message names the option, its value and what is allowed."""


def parse_arguments(argv, program='battery_doctor', wait_s=2.0):
    """``[--wait S] [--sample S]`` -> {'wait': s, 'sample': s}, or UsageError (one line)."""
    options = {'wait': wait_s, 'sample': 3.0}
    rest = list(argv)
    while rest:
        word = rest.pop(0)
        if word in ('-h', '--help'):
            raise UsageError('usage: %s [--wait S] [--sample S]: S seconds of discovery (default %g) and of '
                             'sampling each battery topic (default 3), each in (0, %g]' % (program, wait_s, MAX_WAIT_S))
        name = word[2:] if word.startswith('--') else None
        if '=' in (name or ''):
            name, value = name.split('=', 1)
        elif name in options and rest:
            value = rest.pop(0)
        else:
            value = None
        if name not in options or value is None:
            raise UsageError('%s: unknown argument %r (allowed: --wait S, --sample S)' % (program, word))
        try:
            seconds = float(value)
        except ValueError:
            seconds = math.nan
        if not 0.0 < seconds <= MAX_WAIT_S:
            raise UsageError('%s: --%s %s: must be a number of seconds in (0, %g]' % (program, name, value, MAX_WAIT_S))
        options[name] = seconds
    return options
