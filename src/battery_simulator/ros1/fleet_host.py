"""The fleet host node (battery_fleet): many batteries in one process.

Each robot ``<name>`` gets the interface sim.launch gives inside
``<group ns="<name>">`` (the action, battery_status, the mode parameter, the
services, cmd_vel, charger_contact, low/critical, diagnostics
``<name>/battery_state_pub: Battery``, dynamic_reconfigure at
``/<name>/BatterySimServer``, resume after a crash), built from the same
BatterySimServer and BatteryStatePublisher classes as the two single-robot
nodes. One worker steps every model, one loop publishes every battery_status,
one timer publishes every action status; the server feeds its publisher in
process (no topic between them), and the robots' saved states live in one
parameter, ``~saved_states`` (JSON text: the master stores it without parsing
hundreds of entries), written at most twice a second.

:ROS Parameters:
  - ``~robots`` (int or list): a count N, or a list of ``{name, config, initial_percentage, charging}``
    (every key but name optional) (default 1)
  - ``~prefix`` (str), ``~first`` (int): with a count, names ``<prefix><first + k>`` (default robot, 0)
  - ``~fleet_size``, ``~hosts``, ``~host_index`` (int): set by fleet.launch in place of ``~robots`` and
    ``~first``: this host's even share of fleet_size robots among hosts (checked: one line naming n or hosts)
  - ``~config``, ``~time_scale``, ``~update_rate``, ``~charging``: as battery_sim_server.py, for every robot
  - ``~initial_percentage`` (0..100): every robot's level; unset with a count: staggered 100, 95, ... 20
  - ``~rate``, ``~frame_id``, ``~stale_timeout``, ``~low_percentage``, ``~critical_percentage``,
    ``~hysteresis``: as battery_state_pub.py, for every robot
  - ``~fleet_rate`` (float, Hz, 0 < r <= 100): rate of ``battery_fleet/states`` (default 1)
  - ``~saved_states`` (str, JSON): written by the node; a respawned host resumes every robot from it

:Publishes:
  - ``battery_fleet/states`` (battery_simulator/BatteryFleetState): this host's robots' BatteryStates, while
    subscribed; every host of a fleet publishes on this one topic (a subscriber merges by name)
"""
import resource
import threading
import time

import rospy

from battery_simulator.ros1.action_server import BatterySimServer
from battery_simulator.ros1.battery_settings import read_battery_settings, read_publisher_settings, ros_battery
from battery_simulator.ros1.log import RobotLog
from battery_simulator.ros1.saved_state import FleetStore
from battery_simulator.ros1.state_publisher import BatteryStatePublisher, publish_at_rate, repeat_at_rate
from battery_simulator.ros1.workers import ChangeLoop, DiagnosticsLoop, StatusTimer, UpdateLoop
from battery_simulator.core.config_files import load_yaml
from battery_simulator.core.fleet import (FLEET_SETTINGS, FLEET_STATES, FleetError, fleet_states, host_share,
                                          robot_configs, robot_params, robot_specs)
from battery_simulator.msg import BatteryFleetState
from battery_simulator.ros1.startup import (StartupError, check_one_battery_per_name, checked_param,
                                           ending_the_node_on_error,
                                           exit_on_startup_error, init_node, signals_held,
                                           wait_for_rosout)

#: every host's robots, on one topic (in the hosts' namespace): the whole fleet in one subscription
#: file descriptors one robot holds (rospy: one per topic, service and connection; measured ~13)
FILES_PER_ROBOT = 16
FILES_FOR_THE_PROCESS = 64
#: how often a host lets rospy look for broken connections on every topic (rospy: twice a second, and once
#: more for every connection request: at 250 robots, 3,000 topics, 18 % of the host's CPU measured (py-spy)
CONNECTION_CHECK_PERIOD_S = 5.0


def read_settings():
    """The host's settings and its robots, checked; raises StartupError (one line naming robot and key)."""
    server = read_battery_settings()
    publisher = read_publisher_settings()
    staggered = not rospy.has_param('~initial_percentage')
    try:
        if rospy.has_param('~fleet_size'):   # fleet.launch: this host's share of n robots among hosts
            first, count = host_share(rospy.get_param('~fleet_size'), rospy.get_param('~hosts', 1),
                                      rospy.get_param('~host_index', 0))
        else:
            first = fleet_setting('first')
            count = rospy.get_param('~robots', 1)
        robots = robot_specs(
            count,
            prefix=fleet_setting('prefix'),
            first=first,
            config=server['params_path'], initial_percentage=None if staggered else server['initial_percentage'],
            charging=bool(server['charging']))
    except FleetError as error:
        raise StartupError('%s: %s' % (rospy.get_name(), error)) from None
    try:
        configs = robot_configs(robots, load_yaml, {server['params_path']: server['params']})
    except FleetError as error:
        raise StartupError(str(error)) from None
    return dict(robots=robots, configs=configs, server=server, publisher=publisher,
                fleet_rate=fleet_setting('fleet_rate'))


def fleet_setting(name):
    """The host's private parameter ``~name`` of core's FLEET_SETTINGS, checked by its rule."""
    setting = next(setting for setting in FLEET_SETTINGS if setting.name == name)
    return checked_param('~' + name, setting.default, setting.check, setting.allowed)


def raise_open_file_limit(robots):
    """Raise the soft limit of open files to the hard one (rospy holds one per topic); StartupError if too few."""
    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    needed = FILES_FOR_THE_PROCESS + FILES_PER_ROBOT * robots
    limit = needed if hard == resource.RLIM_INFINITY else hard
    if limit < needed:
        raise StartupError('%s: %d robots need about %d open files, but the hard limit is %d: %d robots fit '
                           '(raise it with ulimit -Hn, or use more hosts: fleet.launch hosts:=...)' % (
                               rospy.get_name(), robots, needed, hard,
                               (hard - FILES_FOR_THE_PROCESS) // FILES_PER_ROBOT))
    if soft != resource.RLIM_INFINITY and soft < limit:
        resource.setrlimit(resource.RLIMIT_NOFILE, (limit, hard))
        rospy.loginfo('open files: soft limit raised from %d to %d for %d robots', soft, limit, robots)


def throttle_connection_checks(period_s=CONNECTION_CHECK_PERIOD_S):
    """Let rospy's registration thread check every topic's connections at most every ``period_s``.

    rospy polls each topic's connections for errors twice a second and after every connection request
    (a subscriber arriving); a host of hundreds of robots holds thousands of topics, so that poll was a
    fifth of its CPU and slowed its start while a thousand subscribers connected. A broken connection is
    still dropped by the first publish that fails on it; this check only tidies up sooner.
    """
    from rospy.impl.registration import get_topic_manager
    manager = get_topic_manager()
    check_all, last = manager.check_all, [0.0]

    def check_all_at_most_every_period():
        now = time.monotonic()
        if now - last[0] >= period_s:
            last[0] = now
            check_all()
    manager.check_all = check_all_at_most_every_period


class FleetHost:
    """The servers and publishers of every robot, and the few threads they share."""

    def __init__(self, robots, configs, server, publisher, fleet_rate):
        self._fleet_rate = fleet_rate
        self.store = FleetStore(rospy.resolve_name('~saved_states'), server['time_scale'])
        self.loop = UpdateLoop(server['update_rate'], after_round=self.store.write_if_due)
        status_timer, self.changes = StatusTimer(), ChangeLoop()
        self.names, self.servers, self.publishers = [], [], []
        for robot in robots:
            namespace = rospy.resolve_name(robot.name) + '/'
            log = RobotLog(robot.name + ': ', progress=False)
            battery = BatterySimServer(
                namespace, namespace + 'BatterySimServer',
                ros_battery(robot_params(configs[robot.config], robot.name),
                            dict(server, initial_percentage=robot.initial_percentage), robot.charging, namespace, log),
                self.store.robot(robot.name), self.loop, status_timer, log)
            status = BatteryStatePublisher(namespace, namespace + 'battery_state_pub', changes=self.changes,
                                           log=log, **publisher)
            battery.add_state_listener(status.on_state)
            status.acknowledge = battery.on_status_sent
            self.names.append(robot.name)
            self.servers.append(battery)
            self.publishers.append(status)
        # every host publishes its robots on the one topic: a subscriber merges by name
        self._states_pub = rospy.Publisher(rospy.resolve_name(FLEET_STATES), BatteryFleetState, queue_size=1)

    def start(self):
        rospy.on_shutdown(self.stop)
        self.loop.start()       # first: each dynamic_reconfigure's first callback waits for an update
        self.changes.start()
        for server in self.servers:
            server.start()
        DiagnosticsLoop(self.publishers).start()
        threading.Thread(target=self._publish_states, name='fleet_states', daemon=True).start()

    def stop(self):
        self.loop.stop()
        self.store.write_if_due(force=True)

    def _publish_states(self):
        """``~states`` at ``~fleet_rate`` (while subscribed)."""
        with ending_the_node_on_error('the fleet state thread'):
            repeat_at_rate(self._fleet_rate, self._publish_states_once)

    def _publish_states_once(self):
        if self._states_pub.get_num_connections() > 0:
            names, batteries = fleet_states(zip(self.names, self.publishers))
            msg = BatteryFleetState(names=names, states=batteries)
            msg.header.stamp = rospy.Time.now()
            self._states_pub.publish(msg)


def main():
    with signals_held():
        settings = init_node('battery_fleet', read_settings)
        throttle_connection_checks()
        try:
            raise_open_file_limit(len(settings['robots']))
            check_one_battery_per_name([rospy.resolve_name(robot.name) + '/' for robot in settings['robots']])
        except StartupError as error:
            exit_on_startup_error(error)
        server = settings['server']
        for key in ('params', 'params_path', 'initial_percentage', 'charging', 'state_file'):
            server.pop(key)
        host = FleetHost(settings['robots'], settings['configs'], server, settings['publisher'],
                         settings['fleet_rate'])
        host.start()
        wait_for_rosout()
        for battery in host.servers:
            battery.report_ready(resumed_only=True)
        rospy.loginfo('battery_fleet ready: %d robots (%s ... %s), time x%g, update %g Hz, battery_status %g Hz',
                      len(host.servers), host.names[0], host.names[-1], server['time_scale'], server['update_rate'],
                      settings['publisher']['rate'])
    publish_at_rate(host.publishers, settings['publisher']['rate'])
    host.stop()
