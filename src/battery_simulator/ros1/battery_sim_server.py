"""battery_sim_server.py's main: the action server node (BatterySimServer in sim.launch), one battery
(ros1/action_server.py), its update loop and its state store. ``read_settings`` is shared with the fleet host.

:ROS Parameters: core/node_settings.py BATTERY_SETTINGS as private parameters (``~config``, ``~time_scale``,
  ``~update_rate``, ``~initial_percentage``, ``~charging``, ``~state_file``, ``~max_time_jump``), listed with
  the topics and services in ros1/action_server.py.
"""
import rospy

from battery_simulator.core.config_files import load_yaml, with_gauge_config
from battery_simulator.core.node_settings import BATTERY_SETTINGS, GAUGE_CONFIG
from battery_simulator.core.parameter_rules import ParameterError
from battery_simulator.ros1.action_server import BatterySimServer
from battery_simulator.ros1.saved_state import StateStore
from battery_simulator.ros1.startup import (StartupError, check_one_battery_per_name, check_state_file_param,
                                            exit_on_startup_error, init_node, read_private_settings, signals_held,
                                            wait_for_rosout)
from battery_simulator.ros1.workers import StatusTimer, UpdateLoop


def read_settings():
    """All start-up parameters (core/node_settings.py BATTERY_SETTINGS), checked; raises StartupError."""
    settings = read_private_settings(BATTERY_SETTINGS + (GAUGE_CONFIG,))
    try:
        settings['params'] = load_yaml(settings['config'])
    except ParameterError as error:
        raise StartupError('parameter %s = %r is invalid: %s' % (rospy.resolve_name('~config'), settings['config'],
                                                                 error)) from None
    try:
        settings['params'] = with_gauge_config(settings['params'], settings.pop('gauge_config'))
    except ParameterError as error:
        raise StartupError('parameter %s is invalid: %s' % (rospy.resolve_name('~gauge_config'), error)) from None
    settings['params_path'] = settings.pop('config')
    check_state_file_param(settings['state_file'])
    return settings


def main():
    with signals_held():
        settings = init_node('BatterySimServer', read_settings)
        try:
            check_one_battery_per_name([rospy.get_namespace()])
        except StartupError as error:
            exit_on_startup_error(error)
        settings.pop('params_path')
        loop = UpdateLoop(settings.pop('update_rate'))
        store = StateStore(rospy.resolve_name('~saved_state'), settings.pop('state_file'))
        server = BatterySimServer(rospy.get_namespace(), rospy.get_name(), store=store, loop=loop,
                                  status_timer=StatusTimer(), **settings)
        rospy.on_shutdown(loop.stop)   # client hooks run before rospy closes the topics
        loop.start()     # first: dynamic_reconfigure's first callback waits for an update
        server.start()
        wait_for_rosout()
        server.report_ready()
    rospy.spin()
    loop.stop()
