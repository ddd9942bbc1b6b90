"""What the rclpy nodes of the robot's loop share: a node's main (declared settings, one fatal line for a bad
one, a clean end on SIGINT or SIGTERM at any moment) and a steady clock for their wall-time timers."""
import rclpy
from rclpy.clock import Clock, ClockType
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node

from battery_simulator.ros2.startup import StartupError, declare_settings, ending_quietly, exit_on_startup_error, spin


def steady_clock():
    return Clock(clock_type=ClockType.STEADY_TIME)


def read_settings(node, settings, defaults=None):
    """The declared, checked settings of ``node``; one fatal line and exit 2 for a bad one."""
    try:
        return declare_settings(node, settings, defaults)
    except StartupError as error:
        exit_on_startup_error(error, node.get_logger())


def run_node(name, settings, make, args=None, defaults=None):
    """A node's main: rclpy.init, Node ``name``, its settings (``defaults`` {name: value} over theirs),
    ``make(node, **settings)``, spin until a signal."""
    with ending_quietly():
        rclpy.init(args=args)
        node = Node(name)
        make(node, **read_settings(node, settings, defaults))
        executor = SingleThreadedExecutor()
        executor.add_node(node)
        spin_until_stopped(executor)


def spin_until_stopped(executor):
    """Spin until a signal. A signal that lands while rclpy converts a message raises a RuntimeError out of
    pybind11 instead of KeyboardInterrupt ("Unable to convert call argument"): after a signal (the context
    is shut down) that is the end too, not a traceback."""
    try:
        spin(executor)
    except RuntimeError:
        if rclpy.ok():
            raise
