"""Building one ROS 2 battery: its settings, its core Battery, its fronts and timers
(shared by ``battery_sim`` and a lone ``battery_state_pub``)."""
import time

from diagnostic_msgs.msg import DiagnosticArray
from rclpy.clock import Clock, ClockType

from battery_simulator.core.battery import LIVE_PARAMETERS, Battery, BatteryError
from battery_simulator.core.parameters import ParameterError, load_yaml
from battery_simulator.core.settings import (BATTERY_SETTINGS, PUBLISHER_SETTINGS, Setting, SettingError,
                                             check_publisher_settings)
from battery_simulator.core.state_file import StateFileKeeper
from battery_simulator.ros2.battery_front import MODE_PARAMETER, BatteryFront
from battery_simulator.ros2.node_log import NodeLog
from battery_simulator.ros2.startup import StartupError, declare_bool, declare_settings, descriptor, parameter_name
from battery_simulator.ros2.status_front import StatusFront

DIAGNOSTIC_PERIOD_S = 0.5
#: the battery settings a ROS 2 node reads at start-up (``charging`` is the live mode parameter instead)
STARTUP_SETTINGS = tuple(s for s in BATTERY_SETTINGS if s.name not in ('charging', 'time_scale'))
TIME_SCALE = next(s for s in BATTERY_SETTINGS if s.name == 'time_scale')


def steady_clock():
    """Timers on wall time: a paused or jumping /clock must not stop updates and publications."""
    return Clock(clock_type=ClockType.STEADY_TIME)


def read_publisher_settings(node):
    try:
        return check_publisher_settings(declare_settings(node, PUBLISHER_SETTINGS),
                                        lambda name: parameter_name(node, name))
    except SettingError as error:
        raise StartupError(str(error)) from None


def load_config(node, path):
    try:
        return load_yaml(path)
    except ParameterError as error:
        raise StartupError('parameter %s = %r is invalid: %s' % (parameter_name(node, 'config'), path, error)) \
            from None


def declare_mode(node, default=False):
    """Declare ``charging``, the mode (its start-up value is the initial mode)."""
    return bool(declare_bool(node, MODE_PARAMETER, default,
                             'the mode (MyRobot/BatteryStatus on ROS 1): true charges, false discharges; '
                             'a goal writes it, a change against an active goal aborts it'))


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
        self.settings = settings = declare_settings(battery_node, STARTUP_SETTINGS + (TIME_SCALE,))
        charging = declare_mode(battery_node)
        publisher = read_publisher_settings(status_node)
        params = load_config(battery_node, settings['config'])
        self.battery = make_battery(battery_node, settings, params, charging, self.log)
        declare_live(battery_node, self.battery)
        self.store = StateFileKeeper(settings['state_file'], self.log.warn) if settings['state_file'] else None
        self.resumed = self._resume()
        self.status = StatusFront(status_node, '', status_node.get_fully_qualified_name().lstrip('/'),
                                  log=NodeLog(status_node.get_logger()), **publisher)
        self.front = BatteryFront(battery_node, self.battery, '', self.log, self.status, self.store)
        battery_node.add_on_set_parameters_callback(self.front.on_set_parameters)
        battery_node.create_timer(1.0 / settings['update_rate'], self.front.update, clock=steady_clock())
        status_node.create_timer(1.0 / publisher['rate'], self.status.publish_once, clock=steady_clock())
        publish_diagnostics(status_node, [self.status])
        self.front.update()

    def _resume(self):
        if self.store is None:
            return None
        saved = self.store.load()
        if saved is None:
            return None
        try:
            self.battery.resume(saved)
        except ValueError as error:
            self.log.warn('not resuming from %s: %s; starting at %.1f %%', self.store.path, error,
                          self.battery.initial_percentage)
            return None
        return self.store.path

    def report_ready(self):
        snapshot = self.battery.snapshot_now()
        if self.resumed:
            self.log.info('battery_simulator resumed from %s: %.1f %%, %.2f cycles, state of health %.1f %%',
                          self.resumed, snapshot.percentage, snapshot.cycle_count, 100.0 * snapshot.state_of_health)
        self.log.info('battery_simulator ready: %s, %.1f %%, %s, %s', self.battery.params.name, snapshot.percentage,
                      snapshot.status.value,
                      'ROS time' if self.battery.sim_time else 'time x%g' % self.battery.time_scale)


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
