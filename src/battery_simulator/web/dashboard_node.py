"""The live dashboard node (battery_dashboard): every sensor_msgs/BatteryState on the master, in a browser.

It finds every BatteryState topic (and, beside each, ``battery_low``,
``battery_critical`` and ``battery_simulator/state``; every fleet host's
``states``), subscribes to them, and serves the page of
``battery_simulator.web.dashboard_app`` with tornado on the main thread. ROS
callbacks write the model under the hub's lock; the web thread reads it.

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
import errno
import functools
import math
import threading
import time

import rospy
import tornado.ioloop
from sensor_msgs.msg import BatteryState
from std_msgs.msg import Bool
from std_srvs.srv import SetBool

from battery_simulator.msg import BatteryFleetState, BatterySimState
from battery_simulator.core import topics
from battery_simulator.ros1.startup import (StartupError, checked_param, exit_on_startup_error, init_node, is_number,
                                           signals_held)
from battery_simulator.srv import InjectFault, SetState
from battery_simulator.web.dashboard_app import (SERVICE_OK, SERVICE_REFUSED, SERVICE_UNREACHABLE, Hub,
                                                bridge_tornado_logs, chart_library_problem, make_app, server_options,
                                                start_pushing)
from battery_simulator.web.dashboard_model import BATTERY_FIELDS, discover, namespace_of

SERVICE_TIMEOUT_S = 2.0
SERVICES = {'set_state': (topics.SET_STATE, SetState), 'set_charging': (topics.SET_CHARGING, SetBool),
            'inject_fault': (topics.INJECT_FAULT, InjectFault)}


def read_settings():
    """All start-up parameters, checked; raises StartupError."""
    return dict(
        host=checked_param('~host', '127.0.0.1', lambda v: isinstance(v, str) and v.strip() != '',
                           'an address to listen on, e.g. 127.0.0.1 or 0.0.0.0'),
        port=int(checked_param('~port', 8090, lambda v: is_number(v) and v == int(v) and 1 <= v <= 65535,
                               'a whole number in [1, 65535]')),
        scan_period=checked_param('~scan_period', 2.0, lambda v: is_number(v) and 0 < v <= 3600,
                                  'a number in (0, 3600] s'),
        history_s=checked_param('~history_s', 600.0, lambda v: is_number(v) and 10 <= v <= 86400,
                                'a number in [10, 86400] s'),
        allow_control=checked_param('~allow_control', False, lambda v: isinstance(v, bool), 'true or false'),
    )


def battery_values(msg):
    """A BatteryState as the plain dict the model takes."""
    values = {field: getattr(msg, field) for field in BATTERY_FIELDS}
    values.update(power_supply_status=msg.power_supply_status, power_supply_health=msg.power_supply_health,
                  location=msg.location, serial_number=msg.serial_number, stamp=msg.header.stamp.to_sec())
    return values


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

    # -- discovery
    def scan(self):
        """Subscribe to new topics, drop those gone (their batteries go stale, then away)."""
        batteries, fleets = discover(rospy.get_published_topics())
        wanted = {}
        for battery, extras in batteries.items():
            wanted[('battery', battery)] = (battery, BatteryState, self._on_battery, battery)
            for kind, message_type, callback in (('low', Bool, self._on_level), ('critical', Bool, self._on_level),
                                                 ('state', BatterySimState, self._on_sim_state)):
                if kind in extras:
                    argument = battery if kind == 'state' else (battery, kind)
                    wanted[(kind, battery)] = (extras[kind], message_type, callback, argument)
        for fleet, host_namespace in fleets.items():
            wanted[('fleet', fleet)] = (fleet, BatteryFleetState, self._on_fleet, (fleet, host_namespace))
        now = time.time()
        with self.hub.lock:
            for battery, extras in batteries.items():
                self.hub.model.add(battery, now, has_controls='state' in extras)
        for key in set(self._subscribers) - set(wanted):
            self._subscribers.pop(key).unregister()
        for key in set(wanted) - set(self._subscribers):
            topic, message_type, callback, argument = wanted[key]
            self._subscribers[key] = rospy.Subscriber(topic, message_type, callback, callback_args=argument,
                                                      queue_size=1)

    def scan_loop(self):
        while not self._stop.is_set() and not rospy.is_shutdown():
            try:
                self.scan()
            except Exception as error:   # noqa: B902 (a master gone a moment: try again next period)
                rospy.logwarn_throttle(30.0, 'battery_dashboard: cannot scan the master (%s)', error)
            self._stop.wait(self.scan_period)

    def stop(self):
        self._stop.set()

    # -- callbacks (rospy's threads)
    def _on_battery(self, msg, battery):
        values = battery_values(msg)
        with self.hub.lock:
            self.hub.model.on_battery(battery, values, time.time())

    def _on_level(self, msg, battery_and_kind):
        battery, kind = battery_and_kind
        with self.hub.lock:
            self.hub.model.on_level_topic(battery, kind, msg.data, time.time())

    def _on_sim_state(self, msg, battery):
        sim = {'charging_state': msg.charging_state, 'time_remaining_s': msg.time_remaining_s,
               'active_faults': list(msg.active_faults), 'cut_off': msg.cut_off, 'cycle_count': msg.cycle_count,
               'state_of_health': msg.state_of_health, 'load_power_w': msg.load_power_w}
        with self.hub.lock:
            self.hub.model.on_sim_state(battery, sim, time.time())

    def _on_fleet(self, msg, fleet_and_namespace):
        """Every host publishes its robots on the one topic (older hosts on their own ``<host>/states``):
        merged by robot name, each robot's host is the node that published it."""
        fleet, host_namespace = fleet_and_namespace
        host = publisher_of(msg) or (fleet[:-len('/states')] if fleet.endswith('/states') else fleet)
        entries = [(name, functools.partial(battery_values, state)) for name, state in zip(msg.names, msg.states)]
        with self.hub.lock:
            self.hub.model.on_fleet_message(host_namespace, host, entries, time.time())

    # -- controls (a web worker thread)
    def call_service(self, battery, action, arguments):
        """Call one of the three services of the battery's simulator; (SERVICE_OK, SERVICE_REFUSED or
        SERVICE_UNREACHABLE, message)."""
        relative, service_type = SERVICES[action]
        name = namespace_of(battery) + relative
        try:
            rospy.wait_for_service(name, timeout=SERVICE_TIMEOUT_S)
            proxy = rospy.ServiceProxy(name, service_type)
            if action == 'set_state':
                response = proxy(percentage=arguments['percentage'], temperature_c=arguments['temperature_c'],
                                 state_of_health=arguments['state_of_health'], gauge_error=float('nan'))
            elif action == 'set_charging':
                response = proxy(arguments['charging'])
            else:
                response = proxy(arguments['fault'], arguments['active'])
        except (rospy.ROSException, rospy.ServiceException) as error:
            return SERVICE_UNREACHABLE, '%s: %s' % (name, error)
        rospy.loginfo('battery_dashboard: %s %s -> %s %s', name, _shown(arguments), response.success,
                      response.message)
        return (SERVICE_OK if response.success else SERVICE_REFUSED), response.message


def _shown(arguments):
    return ', '.join('%s=%s' % (key, 'unchanged' if isinstance(value, float) and math.isnan(value) else value)
                     for key, value in sorted(arguments.items()))


def main():
    bridge_tornado_logs(lambda text: rospy.logwarn('battery_dashboard: %s', text),
                        lambda text: rospy.logerr('battery_dashboard: %s', text))
    with signals_held():
        settings = init_node('battery_dashboard', read_settings)
        hub = Hub(settings['history_s'], settings['allow_control'])
        node = BatteryDashboard(hub, settings['scan_period'])
        hub.call_service = node.call_service if settings['allow_control'] else None
        loop = tornado.ioloop.IOLoop.current()
        try:
            make_app(hub, settings['host'], settings['port'], warn=lambda text: rospy.logwarn('battery_dashboard: %s', text)
                     ).listen(settings['port'], address=settings['host'], **server_options())
            problem = chart_library_problem()
            if problem:
                rospy.logwarn('battery_dashboard: %s', problem)
        except OSError as error:
            if error.errno == errno.EADDRINUSE:
                problem = 'parameter %s = %d is invalid: %s:%d is in use; choose another port' % (
                    rospy.resolve_name('~port'), settings['port'], settings['host'], settings['port'])
            else:   # an address this machine has not (or a name that does not resolve)
                problem = 'parameter %s = %r is invalid: cannot listen on %s:%d (%s)' % (
                    rospy.resolve_name('~host'), settings['host'], settings['host'], settings['port'],
                    error.strerror or error)
            exit_on_startup_error(StartupError(problem),
                                  stop_launch=False)   # dashboard.launch's required="true" ends a launch of it alone
        threading.Thread(target=node.scan_loop, name='dashboard_scan', daemon=True).start()
        start_pushing(hub)
        rospy.on_shutdown(lambda: (node.stop(), loop.add_callback(loop.stop)))
    rospy.loginfo('battery_dashboard: http://%s:%d/ (%s)', settings['host'], settings['port'],
                  'controls on' if settings['allow_control'] else 'read-only')
    loop.start()
