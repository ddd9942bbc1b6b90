"""battery_sim_client.py: send a charge (1) or discharge (0) goal and show progress.

    rosrun battery_simulator battery_sim_client.py 1|0|charge|discharge [--timeout S]

client_cli reads the arguments (before the ROS imports); run() sends the goal.
Exits 0 when the goal succeeds; 1 when it is aborted or preempted, or the
server goes away mid-goal; 2 for bad arguments (no goal is sent); 3 when the
master or the server cannot be reached; 4 on timeout; 130 on Ctrl-C or
SIGTERM (the goal is cancelled first). Timeouts are wall-clock seconds.
"""
import math
import signal
import sys
import threading
import time

import actionlib
import rosgraph
import rospy
from actionlib_msgs.msg import GoalStatus
from sensor_msgs.msg import BatteryState

from battery_simulator.core import ros_names
from battery_simulator.msg import battery_simAction, battery_simGoal
from battery_simulator.cli.progress import ProgressPrinter
from battery_simulator.cli.interrupt import CANCEL_WAIT_S, WAIT_STEP_S, Cancelled, StopRequest, wait_in_wall_time

GOAL_STATES = {GoalStatus.SUCCEEDED: 'succeeded', GoalStatus.ABORTED: 'aborted',
               GoalStatus.PREEMPTED: 'preempted', GoalStatus.REJECTED: 'rejected',
               GoalStatus.RECALLED: 'recalled', GoalStatus.LOST: 'lost'}
LOST_SERVER_S = 3.0   # the server's connection gone this long (wall): the goal is lost


class ProgressView:
    """Redraws one progress line from action feedback and battery_status."""

    def __init__(self, stream):
        self._lock = threading.Lock()
        self._printer = ProgressPrinter(stream)
        self._sub = rospy.Subscriber(ros_names.BATTERY_STATUS, BatteryState, self._on_state, queue_size=1)

    def _on_state(self, msg):
        with self._lock:
            self._printer.state = msg

    def on_feedback(self, feedback):
        with self._lock:
            self._printer.on_feedback(feedback.battery_percentage)


class GoalWatch:
    """Waits for the goal's end in wall time, and notices a server that has gone away."""

    def __init__(self, client):
        self._client = client
        self._done = threading.Event()

    def on_done(self, state, result):
        self._done.set()

    def wait(self, timeout_s, stop):
        """'done', 'timeout' or 'lost' (the server's connection has been gone for LOST_SERVER_S)."""
        deadline = time.monotonic() + timeout_s if timeout_s else math.inf
        gone_since = None
        while not self._done.wait(WAIT_STEP_S):
            stop.check()
            now = time.monotonic()
            if now >= deadline:
                return 'timeout'
            if server_connected(self._client):
                gone_since = None
            elif gone_since is None:
                gone_since = now
            elif now - gone_since >= LOST_SERVER_S:
                return 'lost'
            if rospy.is_shutdown():
                return 'lost'
        return 'done'


def server_connected(client):
    """Whether the action server that last sent a status is still connected to our goal topic."""
    status = client.action_client.last_status_msg
    if status is None:
        return False
    return client.action_client.pub_goal.impl.has_connection(status._connection_header['callerid'])


def wait_for_master(timeout_s, stop):
    master = rosgraph.Master('/battery_sim_client')
    deadline = time.monotonic() + timeout_s
    while not master.is_online():
        stop.check()
        if time.monotonic() >= deadline:
            return False
        time.sleep(WAIT_STEP_S)
    return True


def _exit(code, text, stream=sys.stderr):
    print(text, file=stream)
    sys.exit(code)


def _cancel(client):
    """Cancel the goal and wait (bounded: CANCEL_WAIT_S, wall time) for the server's answer."""
    client.cancel_goal()
    wait_in_wall_time(lambda: client.wait_for_result(rospy.Duration(CANCEL_WAIT_S)), CANCEL_WAIT_S)


def run(args, stop=None):
    """Send the goal of ``args`` (a cli/client_cli.py GoalRequest: charge, timeout, server_timeout) and wait
    for its end. ``stop``: the StopRequest that noted signals while starting (a Ctrl-C then sends nothing)."""
    charge = args.charge
    stop = stop or StopRequest()
    signal.signal(signal.SIGINT, stop.handle)
    signal.signal(signal.SIGTERM, stop.handle)   # SIGTERM cancels the goal, as Ctrl-C does
    client = None
    try:
        stop.check()
        if not wait_for_master(args.server_timeout, stop):
            _exit(3, 'battery_sim_client: no ROS master at %s after %g s'
                  % (rosgraph.get_master_uri(), args.server_timeout))
        rospy.init_node('battery_sim_client', anonymous=True, disable_signals=True)
        action_client = actionlib.SimpleActionClient('battery_simulator', battery_simAction)
        if not wait_in_wall_time(lambda: action_client.wait_for_server(rospy.Duration(0.5)), 1.0, stop):
            print('battery_sim_client: waiting for the action server %s (up to %g s)...'
                  % (rospy.resolve_name('battery_simulator'), args.server_timeout), file=sys.stderr, flush=True)
        if not wait_in_wall_time(action_client.wait_for_server, args.server_timeout, stop):
            _exit(3, 'battery_sim_client: no action server %s after %g s'
                  % (rospy.resolve_name('battery_simulator'), args.server_timeout))
        view = ProgressView(sys.stdout)
        watch = GoalWatch(action_client)
        print('%s the battery...' % ('Charging' if charge else 'Discharging'))
        client = action_client
        client.send_goal(battery_simGoal(charge_state=charge), done_cb=watch.on_done, feedback_cb=view.on_feedback)
        outcome = watch.wait(args.timeout, stop)
    except Cancelled:
        if client is not None:
            _cancel(client)
        _exit(130, '\ncancelled', sys.stdout)
    if sys.stdout.isatty():
        print()
    if outcome == 'timeout':
        _cancel(client)
        _exit(4, 'timed out after %g s; goal cancelled' % args.timeout, sys.stdout)
    if outcome == 'lost':
        _exit(1, 'battery_sim_client: lost the action server %s while the goal was running'
              % rospy.resolve_name('battery_simulator'))
    result = client.get_result()
    state = client.get_state()
    print('Result: %s (%s)' % (result.battery_status if result else '(none)',
                               GOAL_STATES.get(state, 'state %d' % state)))
    sys.exit(0 if state == GoalStatus.SUCCEEDED else 1)
