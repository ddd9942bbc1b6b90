"""The rospy front end (ROS 1): thin adapters around core/ (the battery, its publisher, the fleet host, the
robot's loop, the client), with the same module and class names as ros2/ for the same job."""
from battery_simulator.node_signals import deliver_blocked_sigint, end_nodes_on_signals

end_nodes_on_signals()   # before the nodes import rospy: no signal lost while they start
deliver_blocked_sigint()   # the node scripts' shebang blocks SIGINT while Python loads: delivered now
