"""SIGINT and SIGTERM for the package's ROS 1 nodes: each ends within 2 s at any moment, quietly.

Installed when a node's subpackage is imported (ros1/, ros2/, web/), so a
signal is not lost while the node still imports rospy (a process started in
the background by a shell begins with SIGINT ignored), and the nodes call
rospy.init_node(..., disable_signals=True) so that rospy keeps these handlers.

A signal never runs rospy's shutdown in the handler itself: the main thread may
be inside an XML-RPC call to the master holding a lock that shutdown needs (the
node would hang for ever). A thread of its own runs rospy.signal_shutdown (the
server then ends its goal and saves its state), and a watchdog ends the
process after STOP_GRACE_S whatever it is waiting for (start-up included: there
is nothing to save before a node is up).
"""
import os
import signal
import sys
import threading

STOP_GRACE_S = 1.2
#: the executables that are ROS 1 nodes (scripts/): only their processes get these handlers
NODE_SCRIPTS = ('battery_sim_server.py', 'battery_state_pub.py', 'battery_fleet.py', 'battery_dashboard.py',
                'battery_dock_contact.py', 'battery_cmd_vel_gate.py', 'fake_base.py', 'patrol_and_dock.py',
                'sim_clock.py',
                # ROS 2 (ros2/__init__): until their main takes over before rclpy.init
                'battery_sim', 'battery_state_pub', 'battery_fleet', 'battery_dashboard', 'fake_base',
                'battery_dock_contact', 'battery_cmd_vel_gate', 'patrol_and_dock', 'sim_clock', 'battery_demo')
_stopping = threading.Event()


def _stop(signum, frame):
    if _stopping.is_set():
        return
    _stopping.set()
    watchdog = threading.Timer(STOP_GRACE_S, _exit_now)
    watchdog.daemon = True
    watchdog.start()
    rospy = sys.modules.get('rospy')
    core = getattr(rospy, 'core', None)   # rospy may be half imported
    if core is None or not core.is_initialized():
        _exit_now()   # still starting: nothing to save
    threading.Thread(target=rospy.signal_shutdown, args=('signal %d' % signum,), daemon=True).start()


def _exit_now():
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(0)


def _quiet_once_stopping(hook):
    """An exception hook that ends the process quietly once a stop signal came: the node's main thread may
    meet what rospy's shutdown closed under it (a publish to a closed topic) and nothing is left to do."""
    def quiet(*args):
        if _stopping.is_set():
            _exit_now()
        hook(*args)
    return quiet


def end_nodes_on_signals():
    """Install the handlers in a node's process (idempotent; nothing in a test or a library user's process)."""
    if os.path.basename(sys.argv[0] if sys.argv else '') in NODE_SCRIPTS and \
            threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGINT, _stop)
        signal.signal(signal.SIGTERM, _stop)
        if not getattr(sys.excepthook, 'quiet_once_stopping', False):
            sys.excepthook = _quiet_once_stopping(sys.excepthook)
            sys.excepthook.quiet_once_stopping = True
            threading.excepthook = _quiet_once_stopping(threading.excepthook)


def _interrupted_while_starting(signum, frame):
    os.write(2, ('%s: interrupted while starting\n' % os.path.basename(sys.argv[0])).encode())
    os._exit(130)


def deliver_blocked_sigint():
    """The executables' shebang blocks SIGINT while Python starts (env --block-signal=SIGINT), so that one sent
    then waits, pending, instead of being lost or raising KeyboardInterrupt mid-import: a handler of ours
    (end_nodes_on_signals' for a node, else a one-line exit until a command line sets its own), then unblock."""
    if signal.SIGINT not in signal.pthread_sigmask(signal.SIG_BLOCK, []):
        return
    if signal.getsignal(signal.SIGINT) is signal.default_int_handler:
        signal.signal(signal.SIGINT, _interrupted_while_starting)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})
