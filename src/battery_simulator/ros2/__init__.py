"""The rclpy front end (ROS 2): thin adapters around core/, with the same module and class names as ros1/
for the same job.

A SIGINT while an executable starts is one line at most, never a KeyboardInterrupt traceback: the ROS 2
node executables (scripts/ros2/) start Python with SIGINT blocked (``env --block-signal=SIGINT``), so that
one arriving while Python and its site packages import waits, pending; here, once a handler of ours is in
place (node_signals' for a node, or a one-line exit for a command line until it sets its own), it is
unblocked and delivered.
"""
from battery_simulator.node_signals import deliver_blocked_sigint, end_nodes_on_signals

end_nodes_on_signals()   # while the node imports rclpy: a signal ends it at once, quietly
deliver_blocked_sigint()
