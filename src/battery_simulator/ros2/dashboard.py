"""The live dashboard on ROS 2 (battery_dashboard): every sensor_msgs/msg/BatteryState on the graph, in a browser.

    ros2 run battery_simulator battery_dashboard --ros-args -p port:=8090 -p allow_control:=true

The same pages, API and rules as ROS 1's ``battery_dashboard.py``
(web/dashboard_app.py, web/dashboard_model.py, web/dashboard_rules.py): it
finds every BatteryState topic on the graph (and, beside each,
``battery_low``, ``battery_critical`` and ``battery_simulator/state``; every
``BatteryFleetState`` topic), subscribes to them, and serves the pages with
tornado on the main thread; rclpy's executor runs in a thread of its own and
writes the model under the hub's lock.

Cost: each wake-up of rclpy's executor rebuilds its wait set over every
subscription, so a robot that a fleet host carries on ``/battery_fleet/states``
is read from there (one message a second for the whole fleet) rather than
from its own ``battery_status`` and ``battery_simulator/state``; only its
``battery_low`` / ``battery_critical`` (transient local, said on a change)
are subscribed, on a node of their own (``<name>_levels``, no parameters, no
rosout) spun by an executor of their own, which wakes only when a level
changes, and made on that executor's thread, 100 at a time (made from the
other thread, each woke it into a wait set over all of them). While a fleet topic has not spoken yet (at most 5 s) no robot's own
topics are subscribed: its first message says which robots it carries. New
subscriptions are made 100 at a time, the fleet's first. One timer: the
graph scan (skipped when the graph has not changed).

:Parameters (read-only, checked at start-up: one line and exit 2 for a bad one):
  - ``host`` (str): address to listen on (default 127.0.0.1; 0.0.0.0: every interface)
  - ``port`` (int, 1..65535): TCP port (default 8090)
  - ``scan_period`` (float, s, 0 < p <= 3600): how often the graph is looked at for new topics (default 2)
  - ``history_s`` (float, s, 10 <= h <= 86400): the charts' span; a silent battery leaves after it (default 600)
  - ``allow_control`` (bool): buttons that call set_state, set_charging, inject_fault (default false)

:Subscribes (QoS: whatever the publishers offer, reliable or best effort, transient local or volatile):
  - every ``sensor_msgs/msg/BatteryState`` topic no fleet host carries, its ``<ns>/battery_simulator/state``;
    every battery's ``<ns>/battery_low``, ``<ns>/battery_critical``; every ``BatteryFleetState`` topic
:Calls (only with allow_control):
  - ``<ns>/battery_simulator/set_state``, ``set_charging``, ``inject_fault``
"""
import asyncio
import functools
import threading
import time

import rclpy
import tornado.ioloop
from rclpy.event_handler import SubscriptionEventCallbacks
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import BatteryState
from std_msgs.msg import Bool
from std_srvs.srv import SetBool

from battery_simulator.msg import BatteryFleetState, BatterySimState
from battery_simulator.ros2.rcl_args import init_rclpy
from battery_simulator.ros2.startup import (STOP_S, StartupError, declare_settings, end_process, ending_quietly,
                                            exit_on_startup_error, parameter_name, steady_clock)
from battery_simulator.srv import InjectFault, SetState
from battery_simulator.web.dashboard_app import (SERVICE_OK, SERVICE_REFUSED, SERVICE_UNREACHABLE, Hub,
                                                bridge_tornado_logs, chart_library_problem, make_app, server_options,
                                                start_pushing)
from battery_simulator.web.dashboard_rules import (DASHBOARD_SETTINGS, LEVEL_KINDS, NODE_NAME, SERVICE_WAIT_S,
                                                   battery_values, call_line, finish_settings, fleet_host,
                                                   listen_problem, ready_line, request_fields, ros1_type_name,
                                                   service_name, subscriptions, take_battery, take_level,
                                                   take_sim_state)
from battery_simulator.web.topic_discovery import FLEET_STATE_TYPE, fleet_battery_topic, namespace_of

SERVICE_TYPES = {'set_state': SetState, 'set_charging': SetBool, 'inject_fault': InjectFault}
#: every subscription takes what its publishers offer: a driver's best-effort battery_status as well as the
#: simulator's reliable one, the simulator's transient local battery_low (its latest word at once)
QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1, reliability=ReliabilityPolicy.BEST_AVAILABLE,
                 durability=DurabilityPolicy.BEST_AVAILABLE)
#: the level subscriptions have no QoS event handlers (rclpy's default: incompatible QoS and type, a warning each):
#: the levels executor's wait set, rebuilt at each wake-up, held 2000 subscriptions and 4000 handlers at 1000 robots
NO_EVENTS = SubscriptionEventCallbacks(use_default_callbacks=False)
#: the name of the node that holds the level subscriptions: the dashboard's own name and this
LEVELS_SUFFIX = '_levels'
#: a battery a fleet message named within this long is read from its host's messages
FLEET_SERVED_S = 10.0
#: a fleet topic on the graph that has not spoken yet: until it does (or this long after it was subscribed)
#: no battery's own topics are subscribed, so that a fleet of 1000 is not subscribed robot by robot first
#: and dropped again once its host's message names the robots
FLEET_FIRST_WAIT_S = 5.0
#: new subscriptions made in one pass of the executor's thread; the rest follow a pass every
#: BACKLOG_PERIOD_S, so that the fleet's messages are read in between (2000 level topics at 1000 robots)
SUBSCRIPTIONS_PER_PASS = 100
BACKLOG_PERIOD_S = 0.05
#: the order new subscriptions are made in: the fleet first (it brings every card), the levels last
KIND_ORDER = {'fleet': 0, 'battery': 1, 'state': 2, 'low': 3, 'critical': 3}


def gid_key(gid):
    """A publisher's GID as bytes, from a received message's info (a dict with 'data') or the graph's
    endpoint info (a sequence of ints); the first 16 bytes (what both carry)."""
    if isinstance(gid, dict):
        gid = gid.get('data', b'')
    return bytes(gid)[:16] if gid is not None else b''


class BatteryDashboard(Node):
    """The ROS side: subscriptions that follow the graph, and the service calls."""

    def __init__(self):
        super().__init__(NODE_NAME)
        self.settings = finish_settings(declare_settings(self, DASHBOARD_SETTINGS))
        self.hub = None
        self._subscribed = {}   # (kind, topic) -> Subscription
        self._levels_pending = set()   # level keys handed to the levels executor, not made yet
        self.levels_executor = None    # the levels node's executor (main sets it first): it makes their subscriptions
        self._kinds = {'battery': (BatteryState, self._into_hub(take_battery)),
                       'low': (Bool, self._into_hub(take_level)), 'critical': (Bool, self._into_hub(take_level)),
                       'state': (BatterySimState, self._into_hub(take_sim_state)),
                       'fleet': (BatteryFleetState, self._on_fleet)}
        self._fleet_named = {}     # battery topic -> monotonic time a fleet message last named it
        self._hosts = {}           # publisher GID -> node name (fleet hosts)
        self._service_clients = {}         # service name -> Client
        self._service_lock = threading.Lock()
        self._fleet_heard = set()          # fleet topics that have spoken
        self._fleet_since = {}             # fleet topic -> monotonic time it was subscribed
        self._last_graph = None            # (published, served) of the last scan that looked at them
        self._backlog = []                 # [(key, topic, argument)] still to subscribe, in KIND_ORDER
        self._backlog_timer = None
        #: the level topics' subscriptions (two a robot, transient local, said on a change) on a node of their
        #: own, spun by an executor of their own: they stay out of the wait set that every fleet message and
        #: timer rebuilds (2000 subscriptions there cost 12 ms a wake-up here)
        self.levels = rclpy.create_node(self.get_name() + LEVELS_SUFFIX, namespace=self.get_namespace(),
                                        use_global_arguments=False, start_parameter_services=False,
                                        enable_rosout=False)

    def _owner(self, kind):
        return self.levels if kind in LEVEL_KINDS else self

    def start(self, hub):
        self.hub = hub
        self.scan()
        self.create_timer(self.settings['scan_period'], self.scan, clock=steady_clock())

    # -- discovery (the executor's thread)
    def scan(self):
        """Subscribe to new topics, drop those gone (their batteries go stale, then away)."""
        try:
            published = [(topic, ros1_type_name(topic_type)) for topic, types in self.get_topic_names_and_types()
                         for topic_type in types]
        except Exception as error:   # noqa: B902 (the context is going down: nothing to scan)
            self.get_logger().warning('%s: cannot scan the graph (%s)' % (NODE_NAME, error),
                                      throttle_duration_sec=30.0)
            return
        now = time.monotonic()
        served = frozenset(battery for battery, named in self._fleet_named.items() if now - named < FLEET_SERVED_S)
        waiting = self._fleet_unheard(published, now)
        graph = (frozenset(published), served, waiting)   # whatever order the graph lists them in
        if graph == self._last_graph:   # nothing new on the graph (a fleet of 1000: 15000 topics every scan)
            return
        self._last_graph = graph
        wanted, controls = subscriptions(published, served)
        if waiting:   # only the fleet topics until one speaks: its message says which robots it serves
            wanted = {key: value for key, value in wanted.items() if key[0] == 'fleet'}
        with self.hub.lock:
            for battery, has_controls in controls.items():
                self.hub.model.add(battery, time.time(), has_controls=has_controls)
        for key in set(self._subscribed) - set(wanted):
            if waiting and key[0] != 'fleet':
                continue
            self._owner(key[0]).destroy_subscription(self._subscribed.pop(key))
            if key[0] == 'battery' and key[1] in controls:   # still there: its fleet host's messages bring it
                with self.hub.lock:
                    self.hub.model.own_topics_dropped(key[1])
        self._backlog = sorted(((key,) + wanted[key] for key in set(wanted) - set(self._subscribed) -
                                self._levels_pending),
                               key=lambda entry: (KIND_ORDER[entry[0][0]], entry[0][1]))
        self._subscribe_backlog()

    def _fleet_unheard(self, published, now):
        """A fleet topic on the graph that has not spoken, subscribed less than FLEET_FIRST_WAIT_S ago."""
        for topic, topic_type in published:
            if topic_type == FLEET_STATE_TYPE and topic not in self._fleet_heard:
                if now - self._fleet_since.setdefault(topic, now) < FLEET_FIRST_WAIT_S:
                    return True
        return False

    def _subscribe_backlog(self):
        """Make up to SUBSCRIPTIONS_PER_PASS of the subscriptions still to make; the rest in the next pass."""
        batch, self._backlog = self._backlog[:SUBSCRIPTIONS_PER_PASS], self._backlog[SUBSCRIPTIONS_PER_PASS:]
        levels = []
        for key, topic, argument in batch:
            if key in self._subscribed or key in self._levels_pending:
                continue
            if not self.count_publishers(topic):
                # known only by a subscriber so far: QOS's "best available" would take the strictest policy
                # (transient local) and never match the volatile publisher that comes later; the next scan
                # tries again
                self._last_graph = None
                continue
            message_type, callback = self._kinds[key[0]]
            if key[0] == 'fleet':   # two arguments: rclpy hands the message's info (its publisher) too
                callback = functools.partial(lambda argument, msg, info: self._on_fleet(msg, info, argument), argument)
            else:
                callback = functools.partial(callback, argument=argument)
            if key[0] in LEVEL_KINDS:
                levels.append((key, topic, message_type, callback))
                continue
            self._subscribed[key] = self._owner(key[0]).create_subscription(message_type, topic, callback, QOS)
        if levels:
            self._levels_pending.update(key for key, _, _, _ in levels)
            self.levels_executor.create_task(self._subscribe_levels, levels)
        if self._backlog and self._backlog_timer is None:
            self._backlog_timer = self.create_timer(BACKLOG_PERIOD_S, self._subscribe_backlog, clock=steady_clock())
        elif not self._backlog and self._backlog_timer is not None:
            self.destroy_timer(self._backlog_timer)
            self._backlog_timer = None

    def _subscribe_levels(self, batch):
        """The levels executor's thread: a batch of level subscriptions, one wait set rebuilt after them. Made from
        the other thread, each woke the levels executor, which rebuilt its wait set over every level subscription
        (11 ms at 2000): 1000 robots' 2000 took about 3 minutes, at a quarter of a core."""
        for key, topic, message_type, callback in batch:
            self._subscribed[key] = self.levels.create_subscription(message_type, topic, callback, QOS,
                                                                    event_callbacks=NO_EVENTS)
            self._levels_pending.discard(key)

    # -- callbacks (the executor's thread)
    def _into_hub(self, take):
        """A subscription's callback: ``take`` (web/dashboard_rules.py) puts the message into the hub's model."""
        return lambda msg, argument: take(self.hub, msg, argument)

    def _on_fleet(self, msg, info, argument):
        """Every host publishes its robots on the one topic: merged by robot name, each robot's host is the
        node that published it (found on the graph by the publisher's GID)."""
        fleet, host_namespace = argument
        host = fleet_host(self._publisher_of(fleet, info.get('publisher_gid')), fleet)
        entries = [(name, functools.partial(battery_values, state)) for name, state in zip(msg.names, msg.states)]
        now = time.monotonic()
        with self.hub.lock:
            self.hub.model.on_fleet_message(host_namespace, host, entries, time.time())
        newly_served = False
        for name, _ in entries:
            topic = fleet_battery_topic(host_namespace, name)
            newly_served = newly_served or topic not in self._fleet_named
            self._fleet_named[topic] = now
        if fleet not in self._fleet_heard or newly_served:   # its robots' own topics need no subscription
            self._fleet_heard.add(fleet)
            self.scan()

    def _publisher_of(self, topic, gid):
        """The node that published on ``topic`` with ``gid`` ('' when the graph does not say)."""
        key = gid_key(gid)
        if key and key not in self._hosts:
            for endpoint in self.get_publishers_info_by_topic(topic):
                self._hosts[gid_key(endpoint.endpoint_gid)] = '%s/%s' % (endpoint.node_namespace.rstrip('/'),
                                                                         endpoint.node_name)
        return self._hosts.get(key, '')

    # -- controls (a web worker thread)
    def call_service(self, battery, action, arguments):
        """Call one of the three services of the battery's simulator; (SERVICE_OK, SERVICE_REFUSED or
        SERVICE_UNREACHABLE, message)."""
        name = service_name(namespace_of(battery), action)
        with self._service_lock:
            if name not in self._service_clients:
                self._service_clients[name] = self.create_client(SERVICE_TYPES[action], name)
            client = self._service_clients[name]
        if not client.wait_for_service(timeout_sec=SERVICE_WAIT_S):
            return SERVICE_UNREACHABLE, '%s: service not available within %g s' % (name, SERVICE_WAIT_S)
        done = threading.Event()
        future = client.call_async(SERVICE_TYPES[action].Request(**request_fields(action, arguments)))
        future.add_done_callback(lambda _future: done.set())
        if not done.wait(self.hub.call_timeout_s + 1.0):   # the page has had its 504 by then
            future.cancel()
            return SERVICE_UNREACHABLE, '%s: no answer' % name
        response = future.result()
        if response is None:
            return SERVICE_UNREACHABLE, '%s: no answer' % name
        self.get_logger().info(call_line(name, arguments, response.success, response.message))
        return (SERVICE_OK if response.success else SERVICE_REFUSED), response.message


def serve(node, hub):
    """Listen (one fatal line for a port in use or an address this machine has not) and run the pages on
    this thread's IOLoop until a signal ends it."""
    settings = node.settings
    asyncio.set_event_loop(asyncio.new_event_loop())
    loop = tornado.ioloop.IOLoop.current()
    logger = node.get_logger()

    def warn(text):
        logger.warning('%s: %s' % (NODE_NAME, text))

    def error(text):
        logger.error('%s: %s' % (NODE_NAME, text))
    bridge_tornado_logs(warn, error)
    try:
        make_app(hub, settings['host'], settings['port'], warn=warn).listen(
            settings['port'], address=settings['host'], **server_options())
    except OSError as problem:
        raise StartupError(listen_problem(problem, settings['host'], settings['port'], parameter_name(node, 'host'),
                                          parameter_name(node, 'port'))) from None
    problem = chart_library_problem()
    if problem:
        warn(problem)
    start_pushing(hub)
    return loop


def main(args=None):
    with ending_quietly():
        init_rclpy('battery_dashboard', args)
        node = None
        try:
            node = BatteryDashboard()
            hub = Hub(node.settings['history_s'], node.settings['allow_control'])
            hub.call_service = node.call_service if node.settings['allow_control'] else None
            loop = serve(node, hub)
        except StartupError as error:
            exit_on_startup_error(error, node.get_logger() if node is not None else None)
        stopping = threading.Event()
        levels_executor = SingleThreadedExecutor()
        levels_executor.add_node(node.levels)
        node.levels_executor = levels_executor
        levels_spinner = threading.Thread(target=_spin, args=(levels_executor, stopping), name='levels', daemon=True)
        levels_spinner.start()
        executor = SingleThreadedExecutor()
        executor.add_node(node)
        executor.create_task(node.start, hub)   # the first scan and the timer on the executor's thread
        spinner = threading.Thread(target=_spin, args=(executor, stopping), name='dashboard_ros', daemon=True)
        spinner.start()
        node.get_logger().info(ready_line(node.settings))
        try:
            loop.start()
        except KeyboardInterrupt:   # SIGINT or SIGTERM (ending_quietly's handler)
            pass
        # the spinners stop between waits, then end_process tears rcl down; executor.shutdown() destroyed the guard
        # condition at once, under a spinner a busy machine left in rcl's wait: SIGSEGV (CI beside two CPU hogs)
        stopped_at = time.monotonic()
        stopping.set()
        executor.wake()
        levels_executor.wake()
        end_process(0, stopped_at + STOP_S, threads_in_rcl=(spinner, levels_spinner))


def _spin(executor, stopping):
    try:
        while not stopping.is_set():
            executor.spin_once()
    except Exception:   # noqa: B902 (the context shut down under it: the main thread ends the process)
        pass


if __name__ == '__main__':
    main()
