"""``battery_sim`` (ROS 2): one battery in one process, the two roles of sim.launch (OneBattery, shared with a lone battery_state_pub).

    ros2 run battery_simulator battery_sim [--ros-args -r __ns:=/robot1 -p time_scale:=100 ...]

Nodes ``battery_simulator`` (the model, the action ``battery_simulator``, the
services, ``cmd_vel``, ``charger_contact``, the ``charging`` parameter and the
live settings) and ``battery_state_pub`` (``battery_status``, ``battery_low``,
``battery_critical``, ``/diagnostics``). docs/ros2.md lists every name.

:Parameters of battery_simulator:
  - ``config`` (str, read-only): battery YAML (default: the package's config/battery.yaml)
  - ``time_scale`` (float > 0, live): simulated seconds per wall second (default 22; ignored under use_sim_time)
  - ``update_rate`` (float, Hz, read-only): model updates per second (default 10)
  - ``initial_percentage`` (float 0-100, read-only): charge at start (default 100)
  - ``state_file`` (str, read-only): JSON file the state is saved to and resumed from (a file that exists
    and is not a state file, or a path that cannot be written, stops the node at start with one line)
  - ``charging`` (bool, or 1 / 0, live): the mode; a goal writes it
  - ``load_current_a``, ``load_power_w``, ``charge_current_a``, ``ambient_temperature_c``,
    ``drive_power_w_per_mps``, ``turn_power_w_per_radps`` (float, live): override the config
:Parameters of battery_state_pub:
  - ``rate``, ``frame_id``, ``stale_timeout``, ``low_percentage``, ``critical_percentage``, ``hysteresis``
"""
import time

from diagnostic_msgs.msg import DiagnosticArray
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rcl_interfaces.msg import ParameterDescriptor

from battery_simulator.core.battery import LIVE_PARAMETERS, Battery, BatteryError, parse_mode
from battery_simulator.core.config_files import load_yaml, with_gauge_config
from battery_simulator.core.node_settings import (BATTERY_SETTINGS, GAUGE_CONFIG, PUBLISHER_SETTINGS, Setting,
                                                  SettingError, check_publisher_settings)
from battery_simulator.core.parameter_rules import ParameterError
from battery_simulator.core.resume_rule import resume_battery, say_ready
from battery_simulator.core.state_file import StateFileError, StateFileKeeper, check_state_file
from battery_simulator.ros2 import services
from battery_simulator.ros2.action_server import MODE_PARAMETER, BatterySimServer, mode_refusal
from battery_simulator.ros2.log import NodeLog
from battery_simulator.ros2.battery_claims import BatteryClaim
from battery_simulator.ros2.startup import (StartupError, declare_settings, descriptor, ending_quietly,
                                            exit_on_startup_error, explain_parameter_refusals, init, own_node,
                                            parameter_name, run, steady_clock)
from battery_simulator.ros2.state_publisher import BatteryStatePublisher

DIAGNOSTIC_PERIOD_S = 0.5
STATUS_NODE = 'battery_state_pub'
#: the battery settings a ROS 2 node reads at start-up (``charging`` is the live mode parameter instead)
STARTUP_SETTINGS = tuple(s for s in BATTERY_SETTINGS if s.name not in ('charging', 'time_scale'))
TIME_SCALE = next(s for s in BATTERY_SETTINGS if s.name == 'time_scale')


def read_publisher_settings(node):
    try:
        return check_publisher_settings(declare_settings(node, PUBLISHER_SETTINGS),
                                        lambda name: parameter_name(node, name))
    except SettingError as error:
        raise StartupError(str(error)) from None


def load_config(node, path, gauge_config=''):
    """The battery parameters of ``path``, with the gauge of ``gauge_config`` (a gauge preset's file) if given."""
    try:
        params = load_yaml(path)
    except ParameterError as error:
        raise StartupError('parameter %s = %r is invalid: %s' % (parameter_name(node, 'config'), path, error)) \
            from None
    try:
        return with_gauge_config(params, gauge_config)
    except ParameterError as error:
        raise StartupError('parameter %s is invalid: %s' % (parameter_name(node, 'gauge_config'), error)) from None


def declare_mode(node, default=False):
    """Declare ``charging``, the mode (its start-up value is the initial mode): true / false or 1 / 0 (ROS 1's
    MyRobot/BatteryStatus values, which `-p charging:=1` gives as an integer), anything else one line."""
    value = node.declare_parameter(MODE_PARAMETER, default, ParameterDescriptor(
        description='the mode (MyRobot/BatteryStatus on ROS 1): true (1) charges, false (0) discharges; '
                    'a goal writes it, a change against an active goal aborts it',
        additional_constraints='true, false, 1 or 0', dynamic_typing=True)).value
    if value is None or parse_mode(value) is None:
        raise StartupError('parameter %s' % mode_refusal(value).replace(
            MODE_PARAMETER, parameter_name(node, MODE_PARAMETER), 1))
    return bool(value)


def check_state_path(node, path, fleet=False):
    """StartupError (one line) for a ``state_file`` that exists and is not a state file, or cannot be written."""
    if path:
        try:
            check_state_file(path, fleet, holder=node.get_fully_qualified_name())   # held from now on
        except StateFileError as error:
            raise StartupError('parameter %s = %r is invalid: %s' % (parameter_name(node, 'state_file'), path,
                                                                    error)) from None


def declare_live(node, battery):
    """Declare the live battery settings (LIVE_PARAMETERS), their start-up values applied and checked."""
    for name in LIVE_PARAMETERS:
        value = getattr(battery.params, name)
        setting = Setting(name, value, None, 'a number within the battery config limits',
                          'live battery setting, overrides the config (%s)' % name, True)
        given = node.declare_parameter(name, value, descriptor(setting)).value
        if given != value:
            try:
                battery.set_live(name, given)
            except BatteryError as error:
                raise StartupError('parameter %s = %r is invalid: %s' % (
                    parameter_name(node, name), given, str(error).split('; keeping')[0])) from None


def make_battery(node, settings, params, charging, log, clock_node=None):
    """The core Battery of a node's settings, on the node's ROS time under use_sim_time."""
    clock_node = clock_node or node
    sim_time = bool(clock_node.get_parameter('use_sim_time').value)
    clock = (lambda: clock_node.get_clock().now().nanoseconds * 1e-9) if sim_time else time.monotonic
    return Battery(params, settings['initial_percentage'], charging, clock=clock, sim_time=sim_time,
                   time_scale=settings.get('time_scale', TIME_SCALE.default), mode_name=MODE_PARAMETER, log=log,
                   max_time_jump=settings['max_time_jump'])


class OneBattery:
    """One battery on ``battery_node`` (action, services, parameters) and ``status_node`` (battery_status,
    low/critical, diagnostics): battery_sim's two nodes, or a lone battery_state_pub's one."""

    def __init__(self, battery_node, status_node):
        self.log = NodeLog(battery_node.get_logger())
        self.settings = settings = declare_settings(battery_node, STARTUP_SETTINGS + (TIME_SCALE, GAUGE_CONFIG))
        charging = declare_mode(battery_node)
        publisher = read_publisher_settings(status_node)
        params = load_config(battery_node, settings['config'], settings['gauge_config'])
        check_state_path(battery_node, settings['state_file'])
        self.battery = make_battery(battery_node, settings, params, charging, self.log)
        declare_live(battery_node, self.battery)
        self.store = StateFileKeeper(settings['state_file'], self.log.warn) if settings['state_file'] else None
        self.resumed = self._resume()
        self.status = BatteryStatePublisher(status_node, '', status_node.get_fully_qualified_name().lstrip('/'),
                                  log=NodeLog(status_node.get_logger()), **publisher)
        self.front = BatterySimServer(battery_node, self.battery, '', self.log, self.status, self.store)
        services.start_workers()
        battery_node.add_on_set_parameters_callback(self.front.on_set_parameters)
        battery_node.create_timer(1.0 / settings['update_rate'], self.front.update, clock=steady_clock())
        status_node.create_timer(1.0 / publisher['rate'], self.status.publish_once, clock=steady_clock())
        publish_diagnostics(status_node, [self.status])
        self.front.update()

    def _resume(self):
        if self.store is None:
            return None
        return resume_battery(self.battery, self.store.load(), self.store.path, self.log)

    def report_ready(self):
        say_ready(self.battery, self.log, self.resumed)


def diagnostics_publisher(node, status_fronts):
    """publish(): every status front's "Battery" status in one DiagnosticArray on /diagnostics."""
    publisher = node.create_publisher(DiagnosticArray, '/diagnostics', 10)

    def publish():
        array = DiagnosticArray(status=[front.diagnostic_status() for front in status_fronts])
        array.header.stamp = node.get_clock().now().to_msg()
        publisher.publish(array)
    return publish


def publish_diagnostics(node, status_fronts):
    """The diagnostics twice a second, on a timer of their own (one battery)."""
    return node.create_timer(DIAGNOSTIC_PERIOD_S, diagnostics_publisher(node, status_fronts), clock=steady_clock())


def finish(front):
    """At a stop signal: the front's goal ended and its state saved; predict's workers ended."""
    finished = front.finish()
    services.stop_workers()
    return finished


def status_node_name(battery_node):
    """battery_state_pub, beside the battery node in its namespace whatever ``-r __node:=`` renamed the battery
    node to (a global remap would rename both to one name); never the battery node's own name."""
    return STATUS_NODE if battery_node.get_name() != STATUS_NODE else STATUS_NODE + '_status'


def main(args=None):
    with ending_quietly():
        init(args)
        battery_node = Node('battery_simulator')
        status_node = own_node(status_node_name(battery_node), battery_node.get_namespace())
        executor = SingleThreadedExecutor()
        executor.add_node(battery_node)
        executor.add_node(status_node)
        for node in (battery_node, status_node):
            explain_parameter_refusals(node)
        claim = BatteryClaim(battery_node, [battery_node.get_namespace()],
                             battery_node.get_fully_qualified_name())
        try:
            claim.wait(executor)
            one = OneBattery(battery_node, status_node)
        except StartupError as error:
            exit_on_startup_error(error, battery_node.get_logger())
        one.report_ready()
        run(executor, lambda: finish(one.front), claim)


if __name__ == "__main__":
    main()
