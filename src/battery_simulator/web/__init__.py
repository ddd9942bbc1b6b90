"""The live dashboard (battery_dashboard.py): a ROS-free model and web app, and the node."""
from battery_simulator.node_signals import end_nodes_on_signals

end_nodes_on_signals()   # before the nodes import rospy: no signal lost while they start
