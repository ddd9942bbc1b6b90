"""The rclpy front end (ROS 2): thin adapters around core/battery.py, as battery/ is for rospy."""
from battery_simulator.node_signals import end_nodes_on_signals

end_nodes_on_signals()   # while the node imports rclpy: a signal ends it at once, quietly
