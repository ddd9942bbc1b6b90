"""The battery's ROS side: the action server, the BatteryState publisher and what they share."""
from battery_simulator.node_signals import end_nodes_on_signals

end_nodes_on_signals()   # before the nodes import rospy: no signal lost while they start
