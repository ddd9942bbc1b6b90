"""A battery node's start-up settings read from rclpy's declared parameters (ros1/battery_settings.py's twin):
the battery's (core/node_settings.py BATTERY_SETTINGS and its config, the ``charging`` mode, the live
settings), the publisher's (PUBLISHER_SETTINGS), and the battery built from them by core/battery.py's
new_battery. Shared by battery_sim, battery_state_pub, the demo and the fleet host."""
from rcl_interfaces.msg import ParameterDescriptor

from battery_simulator.core import ros_names
from battery_simulator.core.battery import LIVE_PARAMETERS, BatteryError, new_battery
from battery_simulator.core.node_settings import (BATTERY_SETTINGS, MODE_ALLOWED, PUBLISHER_SETTINGS, Setting,
                                                  SettingError, check_publisher_settings, load_battery_config,
                                                  refusal, setting)
from battery_simulator.core.state_file import StateFileError, check_state_file
from battery_simulator.ros2.action_server import mode_refusal
from battery_simulator.ros2.startup import StartupError, declare_settings, descriptor, parameter_name

#: the battery settings a ROS 2 node reads at start-up (``charging`` is the live mode parameter instead)
STARTUP_SETTINGS = tuple(s for s in BATTERY_SETTINGS if s.name not in ('charging', 'time_scale'))
TIME_SCALE = setting('time_scale')


def read_publisher_settings(node):
    try:
        return check_publisher_settings(declare_settings(node, PUBLISHER_SETTINGS),
                                        lambda name: parameter_name(node, name))
    except SettingError as error:
        raise StartupError(str(error)) from None


def load_config(node, path, gauge_config=''):
    """The battery parameters of ``path``, with the gauge of ``gauge_config`` (a gauge preset's file) if given."""
    try:
        return load_battery_config(path, gauge_config, lambda name: parameter_name(node, name))
    except SettingError as error:
        raise StartupError(str(error)) from None


def declare_mode(node, default=False):
    """Declare ``charging``, the mode (its start-up value is the initial mode): true / false or 1 / 0 (ROS 1's
    MyRobot/BatteryStatus values, which `-p charging:=1` gives as an integer), anything else one line."""
    name = ros_names.CHARGING_PARAM
    value = node.declare_parameter(name, default, ParameterDescriptor(
        description='the mode (MyRobot/BatteryStatus on ROS 1): true (1) charges, false (0) discharges; '
                    'a goal writes it, a change against an active goal aborts it',
        additional_constraints=MODE_ALLOWED, dynamic_typing=True)).value
    reason = mode_refusal(value, parameter_name(node, name))
    if reason is not None:
        raise StartupError(reason)
    return bool(value)


def check_state_path(node, path, fleet=False):
    """StartupError (one line) for a ``state_file`` that exists and is not a state file, or cannot be written."""
    if path:
        try:
            check_state_file(path, fleet, holder=node.get_fully_qualified_name())   # held from now on
        except StateFileError as error:
            raise StartupError(refusal(parameter_name(node, 'state_file'), path, error)) from None


def declare_live(node, battery):
    """Declare the live battery settings (LIVE_PARAMETERS), their start-up values applied and checked."""
    for name in LIVE_PARAMETERS:
        value = getattr(battery.params, name)
        live = Setting(name, value, None, 'a number within the battery config limits',
                       'live battery setting, overrides the config (%s)' % name, True)
        given = node.declare_parameter(name, value, descriptor(live)).value
        if given != value:
            try:
                battery.set_live(name, given)
            except BatteryError as error:
                # the battery's refusal without its run-time "keeping" clause, naming the node's parameter
                reason = str(error).split('; keeping')[0].split(' is invalid: ', 1)[-1]
                raise StartupError(refusal(parameter_name(node, name), given, reason)) from None


def make_battery(node, settings, params, charging, log, clock_node=None):
    """The core Battery of a node's settings (core/battery.py new_battery), on the ROS time of ``clock_node``
    (default ``node``) under use_sim_time."""
    clock_node = clock_node or node
    sim_time = bool(clock_node.get_parameter('use_sim_time').value)
    ros_clock = (lambda: clock_node.get_clock().now().nanoseconds * 1e-9) if sim_time else None
    return new_battery(params, settings, charging, ros_names.CHARGING_PARAM, log, ros_clock)
