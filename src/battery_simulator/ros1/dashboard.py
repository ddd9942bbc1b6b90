"""The live dashboard on ROS 1 (battery_dashboard.py): every sensor_msgs/BatteryState on the master, in a browser.

It finds every BatteryState topic (and, beside each, ``battery_low``,
``battery_critical`` and ``battery_simulator/state``; every fleet host's
``states``), subscribes to them, and serves the page of
``battery_simulator.web.dashboard_app`` with tornado on the main thread. ROS
callbacks write the model under the hub's lock; the web thread reads it. The
rules it shares with ros2/dashboard.py are web/dashboard_rules.py's.

:ROS Parameters:
  - ``~host`` (str): address to listen on (default 127.0.0.1; 0.0.0.0: every interface)
  - ``~port`` (int, 1..65535): TCP port (default 8090)
  - ``~scan_period`` (float, s, 0 < p <= 3600): how often the master is asked for new topics (default 2)
  - ``~history_s`` (float, s, 10 <= h <= 86400): the charts' span; a silent battery leaves after it (default 600)
  - ``~allow_control`` (bool): buttons that call set_state, set_charging, inject_fault (default false)

:Subscribes:
  - every ``sensor_msgs/BatteryState`` topic; ``<ns>/battery_low``, ``<ns>/battery_critical``
    (std_msgs/Bool), ``<ns>/battery_simulator/state`` (battery_simulator/BatterySimState),
    every ``battery_simulator/BatteryFleetState`` topic (``/battery_fleet/states``, where every fleet
    host publishes its robots; an older host's ``<host>/states``), merged by robot name
:Calls (only with ~allow_control):
  - ``<ns>/battery_simulator/set_state``, ``set_charging``, ``inject_fault``
"""
import functools
import threading
import time

import rospy
import tornado.ioloop
from sensor_msgs.msg import BatteryState
from std_msgs.msg import Bool
from std_srvs.srv import SetBool

from battery_simulator.msg import BatteryFleetState, BatterySimState
from battery_simulator.ros1.startup import (StartupError, checked_param, exit_on_startup_error, init_node,
                                            signals_held)
from battery_simulator.srv import InjectFault, SetState
from battery_simulator.web.dashboard_app import (SERVICE_OK, SERVICE_REFUSED, SERVICE_UNREACHABLE, Hub,
                                                bridge_tornado_logs, chart_library_problem, make_app, server_options,
                                                start_pushing)
from battery_simulator.web.dashboard_rules import (DASHBOARD_SETTINGS, NODE_NAME, SERVICE_WAIT_S, battery_values,
                                                   call_line, finish_settings, fleet_host, listen_problem,
                                                   ready_line, request_fields, service_name, subscriptions,
                                                   take_battery, take_level, take_sim_state)
from battery_simulator.web.topic_discovery import namespace_of

SERVICE_TYPES = {'set_state': SetState, 'set_charging': SetBool, 'inject_fault': InjectFault}


def read_settings():
    """All start-up parameters, checked; raises StartupError."""
    return finish_settings({setting.name: checked_param('~' + setting.name, setting.default, setting.check,
                                                        setting.allowed) for setting in DASHBOARD_SETTINGS})


def publisher_of(msg):
    """The node that published a received message ('' when rospy does not say)."""
    header = getattr(msg, '_connection_header', None) or {}
    return header.get('callerid', '')


class BatteryDashboard:
    """The ROS side: subscriptions that follow the master, and the service calls."""

    def __init__(self, hub, scan_period):
        self.hub = hub
        self.scan_period = scan_period
        self._subscribers = {}    # (kind, topic) -> rospy.Subscriber
        self._stop = threading.Event()
        self._kinds = {'battery': (BatteryState, self._into_hub(take_battery)),
                       'low': (Bool, self._into_hub(take_level)), 'critical': (Bool, self._into_hub(take_level)),
                       'state': (BatterySimState, self._into_hub(take_sim_state)),
                       'fleet': (BatteryFleetState, self._on_fleet)}

    # -- discovery
    def scan(self):
        """Subscribe to new topics, drop those gone (their batteries go stale, then away)."""
        wanted, controls = subscriptions(rospy.get_published_topics())
        now = time.time()
        with self.hub.lock:
            for battery, has_controls in controls.items():
                self.hub.model.add(battery, now, has_controls=has_controls)
        for key in set(self._subscribers) - set(wanted):
            self._subscribers.pop(key).unregister()
        for key in set(wanted) - set(self._subscribers):
            topic, argument = wanted[key]
            message_type, callback = self._kinds[key[0]]
            self._subscribers[key] = rospy.Subscriber(topic, message_type, callback, callback_args=argument,
                                                      queue_size=1)

    def scan_loop(self):
        while not self._stop.is_set() and not rospy.is_shutdown():
            try:
                self.scan()
            except Exception as error:   # noqa: B902 (a master gone a moment: try again next period)
                rospy.logwarn_throttle(30.0, '%s: cannot scan the master (%s)', NODE_NAME, error)
            self._stop.wait(self.scan_period)

    def stop(self):
        self._stop.set()

    # -- callbacks (rospy's threads)
    def _into_hub(self, take):
        """A subscription's callback: ``take`` (web/dashboard_rules.py) puts the message into the hub's model."""
        return lambda msg, argument: take(self.hub, msg, argument)

    def _on_fleet(self, msg, fleet_and_namespace):
        """Every host publishes its robots on the one topic (older hosts on their own ``<host>/states``):
        merged by robot name, each robot's host is the node that published it."""
        fleet, host_namespace = fleet_and_namespace
        host = fleet_host(publisher_of(msg), fleet)
        entries = [(name, functools.partial(battery_values, state)) for name, state in zip(msg.names, msg.states)]
        with self.hub.lock:
            self.hub.model.on_fleet_message(host_namespace, host, entries, time.time())

    # -- controls (a web worker thread)
    def call_service(self, battery, action, arguments):
        """Call one of the three services of the battery's simulator; (SERVICE_OK, SERVICE_REFUSED or
        SERVICE_UNREACHABLE, message)."""
        name = service_name(namespace_of(battery), action)
        try:
            rospy.wait_for_service(name, timeout=SERVICE_WAIT_S)
            response = rospy.ServiceProxy(name, SERVICE_TYPES[action])(**request_fields(action, arguments))
        except (rospy.ROSException, rospy.ServiceException) as error:
            return SERVICE_UNREACHABLE, '%s: %s' % (name, error)
        rospy.loginfo(call_line(name, arguments, response.success, response.message))
        return (SERVICE_OK if response.success else SERVICE_REFUSED), response.message


def main():
    bridge_tornado_logs(lambda text: rospy.logwarn('%s: %s', NODE_NAME, text),
                        lambda text: rospy.logerr('%s: %s', NODE_NAME, text))
    with signals_held():
        settings = init_node(NODE_NAME, read_settings)
        hub = Hub(settings['history_s'], settings['allow_control'])
        node = BatteryDashboard(hub, settings['scan_period'])
        hub.call_service = node.call_service if settings['allow_control'] else None
        loop = tornado.ioloop.IOLoop.current()
        try:
            make_app(hub, settings['host'], settings['port'], warn=lambda text: rospy.logwarn('%s: %s', NODE_NAME, text)
                     ).listen(settings['port'], address=settings['host'], **server_options())
            problem = chart_library_problem()
            if problem:
                rospy.logwarn('%s: %s', NODE_NAME, problem)
        except OSError as error:
            exit_on_startup_error(StartupError(listen_problem(error, settings['host'], settings['port'],
                                                              rospy.resolve_name('~host'),
                                                              rospy.resolve_name('~port'))),
                                  stop_launch=False)   # dashboard.launch's required="true" ends a launch of it alone
        threading.Thread(target=node.scan_loop, name='dashboard_scan', daemon=True).start()
        start_pushing(hub)
        rospy.on_shutdown(lambda: (node.stop(), loop.add_callback(loop.stop)))
    rospy.loginfo(ready_line(settings))
    loop.start()
