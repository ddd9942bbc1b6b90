"""``battery_state_pub``'s main on ROS 2: the tutorial's node (ros1/battery_state_pub.py's twin).

    ros2 run battery_simulator battery_state_pub

With a ``battery_simulator`` node in its namespace (found within ``wait_s``,
default 3 s) it publishes that battery's state, as on ROS 1. Alone, it runs
its own battery with the same settings as ``battery_sim`` (they are declared
on this node), so the tutorial's one command gives a physical battery:
``battery_status``, ``battery_low``, ``battery_critical``, ``/diagnostics``,
and the battery's action and services under the usual names.

:Parameters: ``wait_s`` (float >= 0, read-only; default 3), battery_sim's
  battery_state_pub parameters, and (used when alone) battery_sim's
  battery_simulator parameters.
"""
from rcl_interfaces.msg import ParameterDescriptor
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node

from battery_simulator.core import ros_names
from battery_simulator.core.node_settings import refusal
from battery_simulator.core.parameter_rules import is_number
from battery_simulator.ros2.battery_claims import BatteryClaim, check_no_second_publisher, wait_for_battery_node
from battery_simulator.ros2.battery_settings import read_publisher_settings
from battery_simulator.ros2.log import RobotLog
from battery_simulator.ros2.one_battery import OneBattery
from battery_simulator.ros2.startup import (StartupError, ending_quietly, exit_on_startup_error,
                                            explain_parameter_refusals, init, parameter_name, run)
from battery_simulator.ros2.state_publisher import follow_battery


def main(args=None):
    with ending_quietly():
        init(args)
        node = Node(ros_names.STATUS_NODE)
        explain_parameter_refusals(node)
        wait_s = node.declare_parameter('wait_s', 3.0, ParameterDescriptor(
            description='how long to look for a battery_simulator node in this namespace before running '
                        'a battery of its own, s', read_only=True, dynamic_typing=True)).value
        if not (is_number(wait_s) and wait_s >= 0):
            reason = refusal(parameter_name(node, 'wait_s'), wait_s, 'must be a number >= 0 s')
            exit_on_startup_error(StartupError(reason), node.get_logger())
        executor = SingleThreadedExecutor()
        executor.add_node(node)
        log = RobotLog(node.get_logger())
        one = claim = None
        try:
            if wait_for_battery_node(node, executor, wait_s):
                check_no_second_publisher(node, executor)
                follow_battery(node, read_publisher_settings(node), log)
            else:
                claim = BatteryClaim(node, [node.get_namespace()], node.get_fully_qualified_name())
                claim.wait(executor)
                one = OneBattery(node, node)
                log.info('battery_state_pub: no %s node in %s after %g s: running a battery of its own',
                         ros_names.BATTERY_NODE, node.get_namespace(), wait_s)
                one.report_ready()
        except StartupError as error:
            exit_on_startup_error(error, node.get_logger())
        run(executor, one.finish if one is not None else (lambda: (lambda: True)), claim)


if __name__ == "__main__":
    main()
