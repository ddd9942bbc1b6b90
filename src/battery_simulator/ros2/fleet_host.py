"""``battery_fleet`` (ROS 2): N batteries in one process, Part 3's semantics.

    ros2 run battery_simulator battery_fleet --ros-args -p robots:=100
    ros2 run battery_simulator battery_fleet --ros-args -p robots:=/path/robots.yaml

Each robot ``<name>`` gets the names one ``battery_sim`` shows under
``--ros-args -r __ns:=/<name>``: a node ``/<name>/battery_simulator`` with its
own ``charging`` and live parameters, the action, the services, ``cmd_vel``,
``charger_contact``, ``battery_status``, ``battery_low``, ``battery_critical``
and the diagnostics status ``<name>/battery_state_pub: Battery``. One timer at
``update_rate`` (default 1 Hz; a change still acts at once) steps every
battery and publishes the ``battery_status`` that are due (spread over the
ticks of their period where there are several: a burst of hundreds of
reliable messages would delay the last by seconds), the diagnostics and
``/battery_fleet/states`` (BatteryFleetState), which carries the
whole fleet at ``fleet_rate`` Hz.

:Parameters of battery_fleet (read-only):
  - ``robots`` (int, or str): a count N (names ``<prefix><first + k>``) or the path of a YAML file
    holding a list of ``{name, config, initial_percentage, charging}`` (ROS 2 parameters hold no
    list of maps)
  - ``prefix`` (str, default robot), ``first`` (int >= 0, default 0)
  - ``fleet_rate`` (float, Hz, 0 < r <= 100, default 1)
  - ``state_file`` (str): one JSON file every robot's state is saved to and resumed from
  - ``config``, ``time_scale``, ``update_rate``, ``initial_percentage`` (unset with a count: staggered
    100, 95, ... 20), ``charging``, and battery_state_pub's ``rate``, ``frame_id``, ``stale_timeout``,
    ``low_percentage``, ``critical_percentage``, ``hysteresis``: for every robot that does not set its own
"""
import collections
import time

import yaml
from rcl_interfaces.msg import ParameterDescriptor, SetParametersResult
from rclpy.node import Node

from battery_simulator.core.battery import BatteryError
from battery_simulator.core.config_files import load_yaml
from battery_simulator.core.fleet import (FLEET_SETTINGS, FLEET_STATES, ROBOTS_DESCRIPTION, Every, FleetError,
                                          fleet_states, robot_configs, robot_params, robot_specs)
from battery_simulator.core.resume_rule import resume_battery, say_ready
from battery_simulator.core.state_file import FleetStateFile, fleet_save_period_s
from battery_simulator.msg import BatteryFleetState
from battery_simulator.core import ros_names
from battery_simulator.core.ros_names import STATUS_NODE
from battery_simulator.ros2 import prediction_service
from battery_simulator.ros2.action_server import BatterySimServer
from battery_simulator.ros2.battery_settings import (STARTUP_SETTINGS, TIME_SCALE, check_state_path, declare_live,
                                                     declare_mode, make_battery, read_publisher_settings)
from battery_simulator.ros2.events_executor import many_entities_executor
from battery_simulator.ros2.fleet_dds import fleet_profile
from battery_simulator.ros2.log import RobotLog
from battery_simulator.ros2.messages import SimState
from battery_simulator.ros2.saved_state import NoStore
from battery_simulator.ros2.battery_claims import BatteryClaim
from battery_simulator.ros2.startup import (StartupError, child_namespace, declare_settings, descriptor,
                                            ending_quietly, exit_on_startup_error, explain_parameter_refusals, init,
                                            own_node, parameter_name, run, steady_clock, was_given)
from battery_simulator.ros2.state_publisher import BatteryStatePublisher, diagnostics_publisher
from battery_simulator.ros2.velocity import GraphTypes

ROBOT_NODE = 'battery_simulator'
#: a fleet of at most this many robots gives each robot a node ``<ns>/<name>/battery_simulator`` with its parameters
#: (``ros2 param set /robot3/battery_simulator charging true``); a larger one puts every robot's names on the host's
#: node and a robot's mode is set through its services (set_charging, charger_contact, a goal). Measured here:
#: nodes with parameter services cost the square of their number (300: 11.0 s and 376 MB to create; without
#: them 0.4 s and 119 MB), and a fleet of 250 lean nodes took 27 s and 414 MB to start
PARAMETER_SERVICES_UP_TO = 100
FLEET_DIAGNOSTIC_PERIOD_S = 1.0   # a fleet's DiagnosticArray (every robot's status) once a second
#: the fleet host's model updates (and its one timer) per second: once a second (feedback is due once a second;
#: changes act at once), which also kept rclpy's SingleThreadedExecutor's wake-ups (a wait set over every entity) few
FLEET_UPDATE_RATE_HZ = 1.0


def _any(description):
    return ParameterDescriptor(description=description, read_only=True, dynamic_typing=True)


class FleetSettings:
    """The host's parameters, checked: one fatal line for a bad one."""

    def __init__(self, node):
        robots = node.declare_parameter('robots', 1, _any(ROBOTS_DESCRIPTION)).value
        declared = dict(declare_settings(node, FLEET_SETTINGS), robots=robots)
        self.battery = declare_settings(node, STARTUP_SETTINGS + (TIME_SCALE,),
                                        defaults={'update_rate': FLEET_UPDATE_RATE_HZ})
        self.charging = declare_mode(node)
        self.publisher = read_publisher_settings(node)
        staggered = not was_given(node, 'initial_percentage')
        first = declared['first']
        robots = declared['robots']
        if isinstance(robots, str):
            try:
                with open(robots, encoding='utf-8') as stream:
                    robots = yaml.safe_load(stream)
            except (OSError, yaml.YAMLError) as error:
                raise StartupError('parameter %s = %r is invalid: cannot read it as a YAML list of robots (%s)'
                                   % (parameter_name(node, 'robots'), declared['robots'], error)) from None
        try:
            self.robots = robot_specs(robots, prefix=declared['prefix'], first=first, config=self.battery['config'],
                                      initial_percentage=None if staggered else self.battery['initial_percentage'],
                                      charging=self.charging)
        except FleetError as error:
            raise StartupError('%s: %s' % (node.get_fully_qualified_name(), str(error).replace('~', ''))) from None
        self.fleet_rate = declared['fleet_rate']
        check_state_path(node, self.battery['state_file'], fleet=True)
        try:
            self.configs = robot_configs(self.robots, load_yaml)
        except FleetError as error:
            raise StartupError(str(error)) from None


class Robot:
    """One robot of the fleet: its node, battery and fronts."""

    def __init__(self, spec, settings, params, store, executor, host_namespace='/', graph_types=None):
        self.name = spec.name
        self.node = own_node(ROBOT_NODE, child_namespace(host_namespace, spec.name))
        explain_parameter_refusals(self.node)
        executor.add_node(self.node)
        self.log = RobotLog(self.node.get_logger())
        charging = declare_mode(self.node, spec.charging)
        battery_settings = dict(settings.battery, initial_percentage=spec.initial_percentage)
        self.battery = make_battery(self.node, battery_settings, params, charging, self.log)
        declare_live(self.node, self.battery)
        self.node.declare_parameter(TIME_SCALE.name, self.battery.time_scale, descriptor(TIME_SCALE))   # live
        self.store = store.robot(spec.name)
        self.resumed = resume_battery(self.battery, self.store.load(), 'the fleet state file', self.log)
        self.status = BatteryStatePublisher(self.node, '', child_namespace(self.node.get_namespace(), STATUS_NODE)
                                            .lstrip('/'), log=self.log, **settings.publisher)
        self.front = BatterySimServer(self.node, self.battery, '', self.log, self.status, self.store,
                                      graph_types=graph_types)
        self.node.add_on_set_parameters_callback(self.front.on_set_parameters)
        self.update = self.front.update


class SharedRobot:
    """One robot of a large fleet on the host's node: every name of one battery under ``<host ns>/<name>/`` (the
    action, the services, cmd_vel, charger_contact, battery_status, battery_state, low/critical, the diagnostics
    status), no node of its own, so no ``charging`` parameter: its mode is set through ``set_charging``,
    ``charger_contact`` or a goal. A node per robot costs its own endpoints and graph traffic on top of the
    robot's (see PARAMETER_SERVICES_UP_TO). Made in two steps: the battery and its status publishers (battery_status
    runs from the host's first tick), then its action, services and inputs (``add_front``, from the executor)."""

    def __init__(self, spec, settings, params, store, host_node, live, graph_types):
        self.name = spec.name
        self.node = host_node
        self.log = RobotLog(host_node.get_logger().get_child(spec.name))
        battery_settings = dict(settings.battery, initial_percentage=spec.initial_percentage)
        self.battery = make_battery(host_node, battery_settings, params, spec.charging, self.log)
        for name, value in live.items():
            try:
                self.battery.set_live(name, value)
            except BatteryError as error:
                raise StartupError('parameter %s = %r is invalid: %s' % (
                    parameter_name(host_node, name), value, str(error).split('; keeping')[0])) from None
        self.store = store.robot(spec.name)
        self.resumed = resume_battery(self.battery, self.store.load(), 'the fleet state file', self.log)
        self._prefix = spec.name + '/'
        self._graph_types = graph_types
        self.status = BatteryStatePublisher(host_node, self._prefix, child_namespace(
            child_namespace(host_node.get_namespace(), spec.name), STATUS_NODE).lstrip('/'), log=self.log,
            **settings.publisher)
        self.front = None

    def add_front(self):
        """The robot's action, services, cmd_vel and charger_contact."""
        self.front = BatterySimServer(self.node, self.battery, self._prefix, self.log, self.status, self.store,
                                      mode_parameter=False, graph_types=self._graph_types)
        self.front.update()

    def update(self):
        """Step the battery; before its front exists, only what battery_status and the state file need."""
        if self.front is not None:
            self.front.update()
            return
        update = self.battery.update()
        self.status.on_state(SimState(update.record))
        self.store.maybe_save(update.saved_state)


def host_live_settings(node):
    """The live battery settings given to the host (``-p load_power_w:=...``), checked: {name: value} for every
    robot of a shared-node fleet."""
    from battery_simulator.core.battery import LIVE_PARAMETERS
    return {name: node.declare_parameter(name, 0.0, _any('live battery setting of every robot (at start)')).value
            for name in LIVE_PARAMETERS if was_given(node, name)}


class FleetHost:
    """Every robot, and the few timers they share (on the host node)."""

    #: a large fleet's robots get their action, services and inputs in steps of this long on the executor (ticks and a
    #: stop signal served in between) once every battery_status runs: 23 000 of 1000 robots' 27 000 endpoints, which
    #: took 39-72 s on a loaded machine with every battery_status waiting behind them
    FRONT_STEP_S = 0.25
    FRONT_PAUSE_S = 0.01

    def __init__(self, node, settings, executor):
        self._node = node
        save_period_s = fleet_save_period_s(1.0 if node.get_parameter('use_sim_time').value else
                                            settings.battery['time_scale'])
        self._store = FleetStateFile(settings.battery['state_file'], RobotLog(node.get_logger()).warn,
                                     period_s=save_period_s) if settings.battery['state_file'] else NoStore()
        self.shared = len(settings.robots) > PARAMETER_SERVICES_UP_TO
        live = host_live_settings(node) if self.shared else {}
        graph_types = GraphTypes(node)
        # first, before the robots' 27 endpoints each: a process that joins later learns a participant's endpoints in
        # the order they were made (1000 robots: 27000 before it), and a dashboard reads the fleet from this topic
        # rather than subscribing to every robot's own once it knows the topic is there
        self._states_pub = node.create_publisher(BatteryFleetState, FLEET_STATES, 10)
        self.robots = [SharedRobot(spec, settings, robot_params(settings.configs[spec.config], spec.name),
                                   self._store, node, live, graph_types) if self.shared else
                       Robot(spec, settings, robot_params(settings.configs[spec.config], spec.name), self._store,
                             executor, node.get_namespace(), graph_types)
                       for spec in settings.robots]
        for robot in self.robots:
            robot.update()
        self._without_front = collections.deque(robot for robot in self.robots if robot.front is None)
        self._front_timer = self._on_complete = None
        node.add_on_set_parameters_callback(self._on_set_parameters)
        # One timer does everything, at update_rate: the host wakes as seldom as it can (with rclpy's
        # SingleThreadedExecutor each wake-up rebuilt its wait set over every robot's entities). Each robot's
        # battery_status is due on a tick of its own within its period (robot k on tick k mod ticks a period).
        tick_s = 1.0 / settings.battery['update_rate']
        first = time.monotonic() + tick_s
        period_s = 1.0 / settings.publisher['rate']
        ticks = max(1, int(round(period_s / tick_s)))
        self._status_due = [Every(first + tick_s * (k % ticks), period_s, tick_s) for k in range(len(self.robots))]
        self._states_due = Every(first, 1.0 / settings.fleet_rate, tick_s)
        self._diagnostics = diagnostics_publisher(node, [robot.status for robot in self.robots])
        self._diagnostics_due = Every(first, FLEET_DIAGNOSTIC_PERIOD_S, tick_s)
        node.create_timer(tick_s, self._tick, clock=steady_clock())
        if settings.battery['state_file'] and save_period_s < tick_s:
            # an update (300 s of battery at x300, 1 Hz) is more than a resume after SIGKILL may lose
            node.create_timer(save_period_s, self._save, clock=steady_clock())

    def complete(self, on_complete):
        """Give every robot its action, services and inputs (from the executor, FRONT_STEP_S at a time); then
        ``on_complete()``."""
        self._on_complete = on_complete
        self._front_timer = self._node.create_timer(self.FRONT_PAUSE_S, self._add_fronts, clock=steady_clock())

    def _add_fronts(self):
        ends = time.monotonic() + self.FRONT_STEP_S
        while self._without_front and time.monotonic() < ends:
            self._without_front.popleft().add_front()
        if not self._without_front:
            self._node.destroy_timer(self._front_timer)
            self._on_complete()

    def _on_set_parameters(self, parameters):
        """The host's own time_scale and charging: with a node per robot each robot has its own (the host's are their
        start-up values); a shared-node fleet takes a time_scale for every robot (checked, all or none)."""
        for parameter in parameters:
            if parameter.name == ros_names.CHARGING_PARAM or (parameter.name == TIME_SCALE.name and not self.shared):
                return SetParametersResult(successful=False, reason=(
                    "%s of %s is every robot's start-up value: set it on a robot (%s/battery_simulator %s%s)" % (
                        parameter.name, self._node.get_fully_qualified_name(), self.robots[0].name, parameter.name,
                        ', or call its set_charging' if parameter.name == ros_names.CHARGING_PARAM else '')))
            if parameter.name == TIME_SCALE.name and self._without_front:
                return SetParametersResult(successful=False, reason='%s of %s: the fleet is still starting (%d of %d '
                                           'robots without their services); set it once it says ready' % (
                                               parameter.name, self._node.get_fully_qualified_name(),
                                               len(self._without_front), len(self.robots)))
            if parameter.name == TIME_SCALE.name:   # one rule for every robot: the first one's answer is theirs
                first = self.robots[0].front.on_set_parameters([parameter])
                if not first.successful:
                    return first
                for robot in self.robots[1:]:
                    robot.front.on_set_parameters([parameter])
        return SetParametersResult(successful=True)

    def _save(self):
        """Keep every battery's state as it is now (stepped to now) and write the state file."""
        for robot in self.robots:
            robot.battery.advance_to_now()
            robot.store.maybe_save(robot.battery.export_state())
        self._store.write_if_due()

    def _tick(self):
        """Update every battery; publish what is due; then write the state file (written before publishing, its
        65-156 ms on a busy machine made a status's level that much older than its stamp: 0.7 points at x300)."""
        for robot in self.robots:
            robot.update()
        now = time.monotonic()
        for robot, due in zip(self.robots, self._status_due):
            if due.due(now):
                robot.status.publish_once()
        # every robot's status in one array, built only while /diagnostics has a reader: 18 KeyValues a robot,
        # a quarter of a tick's CPU at 1000 robots (cProfile)
        if self._diagnostics_due.due(now) and self._node.count_subscribers(ros_names.DIAGNOSTICS) > 0:
            self._diagnostics()
        if self._states_due.due(now):
            self._publish_states()
        self._store.write_if_due()

    def _publish_states(self):
        if self._states_pub.get_subscription_count() == 0:
            return
        names, batteries = fleet_states((robot.name, robot.status) for robot in self.robots)
        msg = BatteryFleetState(names=names, states=batteries)
        msg.header.stamp = self._node.get_clock().now().to_msg()
        self._states_pub.publish(msg)

    def finish(self):
        """End every robot's goal (aborted, "server shutting down"), save every state; a function telling
        whether every goal's result has gone."""
        finished = [robot.front.finish() for robot in self.robots if robot.front is not None]
        self._store.write_if_due(force=True)
        return lambda: all(done() for done in finished)


def finish(host):
    finished = host.finish()
    prediction_service.stop_workers()
    return finished


def main(args=None):
    with ending_quietly():
        with fleet_profile():
            init(args)
            node = Node('battery_fleet')
        explain_parameter_refusals(node)
        executor = many_entities_executor()
        executor.add_node(node)
        host = claim = None
        try:
            settings = FleetSettings(node)
            claim = BatteryClaim(node, [child_namespace(node.get_namespace(), robot.name) for robot in settings.robots],
                                 '%s (a fleet host)' % node.get_fully_qualified_name())
            claim.wait(executor)
            host = FleetHost(node, settings, executor)
        except StartupError as error:
            exit_on_startup_error(error, node.get_logger())
        prediction_service.start_workers()

        def ready():
            for robot in host.robots:
                if robot.resumed:
                    say_ready(robot.battery, robot.log, robot.resumed, resumed_only=True)
            node.get_logger().info('battery_fleet ready: %d robots (%s ... %s), update %g Hz, battery_status %g Hz' % (
                len(host.robots), host.robots[0].name, host.robots[-1].name, settings.battery['update_rate'],
                settings.publisher['rate']))
        host.complete(ready)
        run(executor, lambda: finish(host), claim)


if __name__ == "__main__":
    main()
