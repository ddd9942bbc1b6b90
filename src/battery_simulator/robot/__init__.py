"""The demo robot's side: a kinematic base, the dock contact, the cut-off gate, patrol and dock."""
from battery_simulator.node_signals import end_nodes_on_signals

end_nodes_on_signals()   # before the nodes import rospy: no signal lost while they start
