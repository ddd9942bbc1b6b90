"""The rospy front end (ROS 1): thin adapters around core/ (the battery, its publisher, the fleet host, the
robot's loop, the client), with the same module and class names as ros2/ for the same job."""
from battery_simulator.node_signals import end_nodes_on_signals

import signal as _signal

end_nodes_on_signals()   # before the nodes import rospy: no signal lost while they start
# The node scripts start Python with SIGINT blocked (their shebang: env --block-signal=SIGINT): a SIGINT sent
# while Python and its site packages load waits, pending, instead of being lost to the SIG_IGN a background
# job inherits; with the handlers above in place it is delivered now.
if _signal.SIGINT in _signal.pthread_sigmask(_signal.SIG_BLOCK, []):
    _signal.pthread_sigmask(_signal.SIG_UNBLOCK, {_signal.SIGINT})
