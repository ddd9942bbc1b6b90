"""What both dashboard nodes do (ros1/dashboard.py on rospy, ros2/dashboard.py on rclpy), written once, without ROS.

Their parameters with their rules, a message as the plain values the model
takes (the same field names in ROS 1 and ROS 2), what to subscribe to on the
graph, the services the controls call and the lines a node says.
"""
import errno
import math
import time

from battery_simulator.core import ros_names
from battery_simulator.core.node_settings import Setting
from battery_simulator.core.parameter_rules import is_number, refusal
from battery_simulator.web.dashboard_model import BATTERY_FIELDS
from battery_simulator.web.topic_discovery import discover

NODE_NAME = 'battery_dashboard'
#: a control's service not there within this: unreachable (502); the web app's CALL_TIMEOUT_S bounds the call
SERVICE_WAIT_S = 2.0
#: action -> the service's name relative to the battery's namespace (ROS 1 and ROS 2 types of the same names)
SERVICE_NAMES = {'set_state': ros_names.SET_STATE, 'set_charging': ros_names.SET_CHARGING,
                 'inject_fault': ros_names.INJECT_FAULT}
#: the extras beside a battery, by kind: (what discover calls them, message type name)
LEVEL_KINDS = ('low', 'critical')
#: the simulator's fields of BatterySimState the model takes
SIM_FIELDS = ('charging_state', 'time_remaining_s', 'active_faults', 'cut_off', 'cycle_count', 'state_of_health',
              'load_power_w')


def _port(value):
    return is_number(value) and value == int(value) and 1 <= value <= 65535


#: the start-up parameters (ROS 1: private ``~name``; ROS 2: declared, read-only, with a descriptor)
DASHBOARD_SETTINGS = (
    Setting('host', '127.0.0.1', lambda v: isinstance(v, str) and v.strip() != '',
            'an address to listen on, e.g. 127.0.0.1 or 0.0.0.0',
            'address to listen on (0.0.0.0: every interface)', False),
    Setting('port', 8090, _port, 'a whole number in [1, 65535]', 'TCP port of the pages', False),
    Setting('scan_period', 2.0, lambda v: is_number(v) and 0 < v <= 3600, 'a number in (0, 3600] s',
            'how often the graph is looked at for new battery topics, s', False),
    Setting('history_s', 600.0, lambda v: is_number(v) and 10 <= v <= 86400, 'a number in [10, 86400] s',
            "the charts' span; a silent battery leaves the page after it, s", False),
    Setting('allow_control', False, lambda v: isinstance(v, bool), 'true or false',
            'buttons that call set_state, set_charging and inject_fault (default: read-only)', False),
)


def finish_settings(values):
    """The checked parameters as the node uses them (the port as an int)."""
    return dict(values, port=int(values['port']))


# -- messages -> the model's values --------------------------------------------------------

def stamp_seconds(stamp):
    """A header stamp in seconds: ROS 1's rospy.Time (secs, nsecs) or ROS 2's builtin_interfaces/Time
    (sec, nanosec)."""
    if hasattr(stamp, 'nanosec'):
        return stamp.sec + stamp.nanosec * 1e-9
    return stamp.secs + stamp.nsecs * 1e-9


def battery_values(msg):
    """A BatteryState as the plain dict the model takes."""
    values = {field: getattr(msg, field) for field in BATTERY_FIELDS}
    values.update(power_supply_status=msg.power_supply_status, power_supply_health=msg.power_supply_health,
                  location=msg.location, serial_number=msg.serial_number, stamp=stamp_seconds(msg.header.stamp))
    return values


def sim_values(msg):
    """A BatterySimState's extras as the plain dict the model takes."""
    values = {field: getattr(msg, field) for field in SIM_FIELDS}
    values['active_faults'] = list(values['active_faults'])
    return values


def take_battery(hub, msg, battery):
    """A BatteryState of ``battery``'s topic into the hub's model (both nodes' subscription callback)."""
    values = battery_values(msg)
    with hub.lock:
        hub.model.on_battery(battery, values, time.time())


def take_level(hub, msg, battery_and_kind):
    """A battery_low / battery_critical Bool of ``battery`` (``kind``: low or critical) into the hub's model."""
    battery, kind = battery_and_kind
    with hub.lock:
        hub.model.on_level_topic(battery, kind, msg.data, time.time())


def take_sim_state(hub, msg, battery):
    """A BatterySimState of ``battery``'s server into the hub's model."""
    sim = sim_values(msg)
    with hub.lock:
        hub.model.on_sim_state(battery, sim, time.time())


def fleet_host(publisher, fleet_topic):
    """The host a fleet message names: its publishing node, else the topic's namespace ('/x/states' -> '/x')."""
    if publisher:
        return publisher
    return fleet_topic[:-len('/states')] if fleet_topic.endswith('/states') else fleet_topic


# -- what to subscribe to --------------------------------------------------------------------

def subscriptions(published, fleet_served=()):
    """What to subscribe to, from the graph's [(topic, type)] (ROS 1 type names: pkg/Type).

    Returns ({(kind, battery or fleet topic): (topic to subscribe, argument of the callback)},
    {battery topic: has the simulator's controls}). Kinds: 'battery' (BatteryState), 'low' and
    'critical' (Bool, argument (battery, kind)), 'state' (BatterySimState), 'fleet'
    (BatteryFleetState, argument (fleet topic, its host's namespace)). A battery in
    ``fleet_served`` (a fleet host carries it) gets neither its own BatteryState nor its state
    subscribed: its host's fleet message brings them, one message for the whole fleet."""
    batteries, fleets = discover(published)
    wanted = {}
    for battery, extras in batteries.items():
        if battery not in fleet_served:
            wanted[('battery', battery)] = (battery, battery)
            if 'state' in extras:
                wanted[('state', battery)] = (extras['state'], battery)
        for kind in LEVEL_KINDS:
            if kind in extras:
                wanted[(kind, battery)] = (extras[kind], (battery, kind))
    for fleet, host_namespace in fleets.items():
        wanted[('fleet', fleet)] = (fleet, (fleet, host_namespace))
    return wanted, {battery: 'state' in extras for battery, extras in batteries.items()}


def ros1_type_name(ros2_type):
    """'sensor_msgs/msg/BatteryState' -> 'sensor_msgs/BatteryState' (the model's names)."""
    parts = ros2_type.split('/')
    return '%s/%s' % (parts[0], parts[-1]) if len(parts) == 3 else ros2_type


# -- the controls ---------------------------------------------------------------------------------

def service_name(namespace, action):
    """The full name of ``action``'s service of the battery in ``namespace`` ('/robot3/')."""
    return namespace + SERVICE_NAMES[action]


def request_fields(action, arguments):
    """The checked arguments of a control (dashboard_app.control_request) as the request's fields."""
    if action == 'set_state':
        return dict(percentage=arguments['percentage'], temperature_c=arguments['temperature_c'],
                    state_of_health=arguments['state_of_health'], gauge_error=math.nan)
    if action == 'set_charging':
        return dict(data=arguments['charging'])
    return dict(fault=arguments['fault'], active=arguments['active'])


def call_line(name, arguments, success, message):
    """The log line of a control's call."""
    shown = ', '.join('%s=%s' % (key, 'unchanged' if isinstance(value, float) and math.isnan(value) else value)
                      for key, value in sorted(arguments.items()))
    return '%s: %s %s -> %s %s' % (NODE_NAME, name, shown, success, message)


# -- start-up ------------------------------------------------------------------------------------

def listen_problem(error, host, port, host_name, port_name):
    """The fatal line for an OSError of listening on host:port (``host_name``/``port_name``: how the node
    names its parameters)."""
    if error.errno == errno.EADDRINUSE:
        return refusal(port_name, port, '%s:%d is in use; choose another port' % (host, port))
    # an address this machine has not (or a name that does not resolve)
    return refusal(host_name, host, 'cannot listen on %s:%d (%s)' % (host, port, error.strerror or error))


def page_url(host, port):
    """The address a browser opens: an IPv6 host in brackets ('::' -> 'http://[::]:8090/')."""
    host = host.strip()
    if ':' in host and not host.startswith('['):
        host = '[%s]' % host
    return 'http://%s:%d/' % (host, port)


def ready_line(settings):
    return '%s: %s (%s)' % (NODE_NAME, page_url(settings['host'], settings['port']),
                            'controls on' if settings['allow_control'] else 'read-only')
