"""The rclpy front end (ROS 2): thin adapters around core/, with the same module and class names as ros1/
for the same job."""
from battery_simulator.node_signals import end_nodes_on_signals

end_nodes_on_signals()   # while the node imports rclpy: a signal ends it at once, quietly
