"""What the rclpy nodes of the robot's loop share: a node's main (declared settings, one fatal line for a bad
one, a clean end on SIGINT or SIGTERM at any moment)."""
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node

from battery_simulator.ros2.startup import (StartupError, declare_settings, ending_quietly, exit_on_startup_error, init,
                                            run)


def read_settings(node, settings, defaults=None):
    """The declared, checked settings of ``node``; one fatal line and exit 2 for a bad one."""
    try:
        return declare_settings(node, settings, defaults)
    except StartupError as error:
        exit_on_startup_error(error, node.get_logger())


def nothing_to_finish():
    """``run``'s finish for a node with nothing to save: done at once."""
    return lambda: True


def run_node(name, settings, make, args=None, defaults=None):
    """A node's main: ``init``, Node ``name``, its settings (``defaults`` {name: value} over theirs),
    ``make(node, **settings)``, spin until SIGINT or SIGTERM (ros2/startup.py's ``run``; then the role's
    ``finish()`` if it has one)."""
    with ending_quietly():
        init(args)
        node = Node(name)
        role = make(node, **read_settings(node, settings, defaults))
        executor = SingleThreadedExecutor()
        executor.add_node(node)
        run(executor, getattr(role, 'finish', nothing_to_finish))
