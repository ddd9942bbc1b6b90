"""A battery node's start-up settings read from rospy's private parameters (ros2/battery_settings.py's twin):
the battery's (core/node_settings.py BATTERY_SETTINGS and its config), the publisher's (PUBLISHER_SETTINGS),
and the battery built from them by core/battery.py's new_battery. Shared by battery_sim, battery_state_pub
and the fleet host."""
import rospy

from battery_simulator.core import ros_names
from battery_simulator.core.battery import new_battery
from battery_simulator.core.node_settings import (BATTERY_SETTINGS, GAUGE_CONFIG, PUBLISHER_SETTINGS, SettingError,
                                                  check_publisher_settings, load_battery_config)
from battery_simulator.ros1.startup import StartupError, check_state_file_param, read_private_settings


def private_name(name):
    """How a start-up line names a private parameter: its resolved name (/BatterySimServer/config)."""
    return rospy.resolve_name('~' + name)


def read_battery_settings():
    """All of a battery's start-up parameters, checked, with ``params`` (its config) and ``params_path``;
    raises StartupError (one line naming the parameter)."""
    settings = read_private_settings(BATTERY_SETTINGS + (GAUGE_CONFIG,))
    try:
        settings['params'] = load_battery_config(settings['config'], settings.pop('gauge_config'), private_name)
    except SettingError as error:
        raise StartupError(str(error)) from None
    settings['params_path'] = settings.pop('config')
    check_state_file_param(settings['state_file'])
    return settings


def read_publisher_settings():
    """battery_state_pub's start-up parameters, checked; raises StartupError."""
    try:
        return check_publisher_settings(read_private_settings(PUBLISHER_SETTINGS), private_name,
                                        lambda name: '~' + name)
    except SettingError as error:
        raise StartupError(str(error)) from None


def ros_battery(params, settings, charging, namespace, log):
    """The core Battery of one robot (core/battery.py new_battery) whose names live under ``namespace``: on
    ROS time under /use_sim_time, its mode the robot's MyRobot/BatteryStatus."""
    sim_time = bool(rospy.get_param('/use_sim_time', False))
    return new_battery(params, settings, charging, rospy.resolve_name(namespace + ros_names.MODE_PARAM), log,
                       ros_clock=rospy.get_time if sim_time else None)
