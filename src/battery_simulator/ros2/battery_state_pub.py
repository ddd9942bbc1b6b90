"""``battery_state_pub`` (ROS 2): the tutorial's node.

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
import time

from rcl_interfaces.msg import ParameterDescriptor
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node

from battery_simulator.core.parameter_rules import is_number
from battery_simulator.msg import BatterySimState
from battery_simulator.core import ros_names
from battery_simulator.ros2.battery_sim import OneBattery, finish, publish_diagnostics, read_publisher_settings
from battery_simulator.ros2.log import NodeLog
from battery_simulator.ros2.battery_claims import BatteryClaim, claimed_by
from battery_simulator.ros2.startup import (StartupError, ending_quietly,
                                            exit_on_startup_error, explain_parameter_refusals, init, parameter_name,
                                            run, steady_clock)
from battery_simulator.ros2.messages import ReceivedState
from battery_simulator.ros2.qos import STATUS_QOS
from battery_simulator.ros2.state_publisher import BatteryStatePublisher

BATTERY_NODE = 'battery_simulator'


def battery_node_present(node):
    """Whether a node named battery_simulator runs in this node's namespace."""
    namespace = node.get_namespace()
    return any(name == BATTERY_NODE and ns == namespace for name, ns in node.get_node_names_and_namespaces())


def other_state_pub(node):
    """Whether another node named battery_state_pub runs in this node's namespace (battery_sim's)."""
    namespace, name = node.get_namespace(), node.get_name()
    return sum(1 for n, ns in node.get_node_names_and_namespaces() if n == name and ns == namespace) > 1


def status_published_by_battery(node, executor, timeout_s=1.0):
    """Whether this namespace's battery_simulator node publishes battery_status itself (a fleet host's
    robot does; battery_sim's battery leaves it to its battery_state_pub), looked for up to ``timeout_s``."""
    topic = node.resolve_topic_name(ros_names.BATTERY_STATUS)
    namespace = node.get_namespace()
    deadline = time.monotonic() + timeout_s
    while True:
        if any(info.node_name == BATTERY_NODE and info.node_namespace == namespace
               for info in node.get_publishers_info_by_topic(topic)):
            return True
        if time.monotonic() >= deadline:
            return False
        executor.spin_once(timeout_sec=0.1)


def wait_for_battery_node(node, executor, wait_s):
    deadline = time.monotonic() + wait_s
    while time.monotonic() < deadline:
        if battery_node_present(node):
            return True
        executor.spin_once(timeout_sec=0.1)
    return battery_node_present(node)


def main(args=None):
    with ending_quietly():
        init(args)
        node = Node('battery_state_pub')
        explain_parameter_refusals(node)
        wait_s = node.declare_parameter('wait_s', 3.0, ParameterDescriptor(
            description='how long to look for a battery_simulator node in this namespace before running '
                        'a battery of its own, s', read_only=True, dynamic_typing=True)).value
        if not (is_number(wait_s) and wait_s >= 0):
            exit_on_startup_error(StartupError('parameter %s = %r is invalid: must be a number >= 0 s'
                                               % (parameter_name(node, 'wait_s'), wait_s)), node.get_logger())
        executor = SingleThreadedExecutor()
        executor.add_node(node)
        log = NodeLog(node.get_logger())
        one = claim = None
        try:
            if wait_for_battery_node(node, executor, wait_s):
                if other_state_pub(node):
                    raise StartupError('%s already runs beside the battery of %s (battery_sim runs both): a second '
                                       'one would publish every battery_status twice; battery_state_pub alone is '
                                       'for a namespace without battery_sim' % (
                                           node.get_fully_qualified_name(), node.get_namespace()))
                if status_published_by_battery(node, executor):
                    host = claimed_by(node, executor, node.get_namespace()) or '%s/%s' % (
                        node.get_namespace().rstrip('/'), BATTERY_NODE)
                    raise StartupError('battery_status of %s is already published by %s (its battery and '
                                       'battery_status are one node): a second battery_state_pub would publish '
                                       'it twice; battery_state_pub alone is for a namespace without one' % (
                                           node.get_namespace(), host))
                publisher = read_publisher_settings(node)
                status = BatteryStatePublisher(node, '', node.get_fully_qualified_name().lstrip('/'), log=log, **publisher)
                node.create_subscription(BatterySimState, ros_names.STATE_TOPIC,
                                         lambda msg: status.on_state(ReceivedState(msg), msg.publish_now),
                                         STATUS_QOS)
                node.create_timer(1.0 / publisher['rate'], status.publish_once, clock=steady_clock())
                publish_diagnostics(node, [status])
                log.info('battery_state_pub: following %s', node.resolve_topic_name(ros_names.STATE_TOPIC))
            else:
                claim = BatteryClaim(node, [node.get_namespace()], node.get_fully_qualified_name())
                claim.wait(executor)
                one = OneBattery(node, node)
                log.info('battery_state_pub: no %s node in %s after %g s: running a battery of its own',
                         BATTERY_NODE, node.get_namespace(), wait_s)
                one.report_ready()
        except StartupError as error:
            exit_on_startup_error(error, node.get_logger())
        run(executor, lambda: finish(one.front) if one is not None else (lambda: True), claim)


if __name__ == "__main__":
    main()
