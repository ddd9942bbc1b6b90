"""The rclpy front end (ROS 2): thin adapters around core/, with the same module and class names as ros1/
for the same job.

A SIGINT while an executable starts is one line at most, never a KeyboardInterrupt traceback: the ROS 2
node executables (scripts/ros2/) start Python with SIGINT blocked (``env --block-signal=SIGINT``), so that
one arriving while Python and its site packages import waits, pending; here, once a handler of ours is in
place (node_signals' for a node, or a one-line exit for a command line until it sets its own), it is
unblocked and delivered.
"""
import os as _os
import signal as _signal
import sys as _sys

from battery_simulator.node_signals import end_nodes_on_signals


def _interrupted_while_starting(signum, frame):
    _os.write(2, ('%s: interrupted while starting\n' % _os.path.basename(_sys.argv[0])).encode())
    _os._exit(130)


def _deliver_blocked_sigint():
    """The executables' shebang blocks SIGINT while Python starts: a handler of ours, then unblock it."""
    if _signal.SIGINT not in _signal.pthread_sigmask(_signal.SIG_BLOCK, []):
        return
    if _signal.getsignal(_signal.SIGINT) is _signal.default_int_handler:
        _signal.signal(_signal.SIGINT, _interrupted_while_starting)
    _signal.pthread_sigmask(_signal.SIG_UNBLOCK, {_signal.SIGINT})


end_nodes_on_signals()   # while the node imports rclpy: a signal ends it at once, quietly
_deliver_blocked_sigint()
