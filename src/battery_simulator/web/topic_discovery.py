"""Which batteries a graph holds, without ROS: the master's or the ROS 2 graph's [(topic, type)] -> the
battery topics with their level and state extras, and the fleet state topics with their host's namespace."""
import collections

BATTERY_TYPE = 'sensor_msgs/BatteryState'
BOOL_TYPE = 'std_msgs/Bool'
SIM_STATE_TYPE = 'battery_simulator/BatterySimState'
FLEET_STATE_TYPE = 'battery_simulator/BatteryFleetState'


def discover(published):
    """The batteries in the master's [(topic, type)] list, and what to subscribe for each.

    Returns {battery topic: {'low': topic, 'critical': topic, 'state': topic}} (only the
    extras that exist) and {fleet state topic: namespace of its host}. A battery's extras
    live in its namespace (``<ns>/battery_low``, ``<ns>/battery_critical``,
    ``<ns>/battery_simulator/state``); they belong to it when it is the namespace's
    ``battery_status`` or the namespace's only battery. A ``<ns>/battery_state`` beside a
    ``<ns>/battery_status`` is the simulator's twin of it (what opennav_docking reads): one battery, shown once.
    """
    types = {}
    for topic, topic_type in published:
        types[topic] = topic_type
    batteries = sorted(topic for topic, topic_type in types.items() if topic_type == BATTERY_TYPE
                       and not (topic.endswith('/battery_state')
                                and types.get(topic[:-len('battery_state')] + 'battery_status') == BATTERY_TYPE))
    per_namespace = collections.Counter(namespace_of(topic) for topic in batteries)
    found = {}
    for topic in batteries:
        namespace = namespace_of(topic)
        extras = {}
        if topic.endswith('/battery_status') or per_namespace[namespace] == 1:
            for key, name, wanted in (('low', 'battery_low', BOOL_TYPE), ('critical', 'battery_critical', BOOL_TYPE),
                                      ('state', 'battery_simulator/state', SIM_STATE_TYPE)):
                extra = namespace.rstrip('/') + '/' + name
                if types.get(extra) == wanted:
                    extras[key] = extra
        found[topic] = extras
    fleets = {topic: namespace_of(namespace_of(topic).rstrip('/'))
              for topic, topic_type in types.items() if topic_type == FLEET_STATE_TYPE}
    return found, fleets


def namespace_of(name):
    """'/robot3/battery_status' -> '/robot3/'; '/battery_status' -> '/'."""
    return name[:name.rstrip('/').rfind('/') + 1] or '/'



def fleet_battery_topic(host_namespace, robot_name):
    """The battery_status topic of robot ``robot_name`` of a fleet host in ``host_namespace``."""
    return host_namespace + robot_name.strip('/') + '/battery_status'
