"""battery_sim_client.py: send a charge (1) or discharge (0) goal and show progress.

    rosrun battery_simulator battery_sim_client.py 1|0|charge|discharge [--timeout S]

Exits 0 when the goal succeeds; 1 when it is aborted or preempted; 2 for bad
arguments (no goal is sent); 3 when the server cannot be reached; 4 on
timeout; 130 on Ctrl-C (the goal is cancelled first).
"""
import argparse
import sys
import threading

import actionlib
import rospy
from actionlib_msgs.msg import GoalStatus
from sensor_msgs.msg import BatteryState

from battery_simulator.msg import battery_simAction, battery_simGoal

CHOICES = {'1': True, 'charge': True, '0': False, 'discharge': False}
SUPPLY_STATUS = {BatteryState.POWER_SUPPLY_STATUS_CHARGING: 'charging',
                 BatteryState.POWER_SUPPLY_STATUS_DISCHARGING: 'discharging',
                 BatteryState.POWER_SUPPLY_STATUS_FULL: 'full',
                 BatteryState.POWER_SUPPLY_STATUS_NOT_CHARGING: 'not charging'}
GOAL_STATES = {GoalStatus.SUCCEEDED: 'succeeded', GoalStatus.ABORTED: 'aborted',
               GoalStatus.PREEMPTED: 'preempted', GoalStatus.REJECTED: 'rejected',
               GoalStatus.RECALLED: 'recalled', GoalStatus.LOST: 'lost'}
BAR_WIDTH = 30


def parse_arguments(argv):
    parser = argparse.ArgumentParser(
        prog='battery_sim_client.py', description='Charge or discharge the simulated battery.')
    parser.add_argument('goal', choices=sorted(CHOICES), metavar='{1,0,charge,discharge}',
                        help='1 or charge: charge to full; 0 or discharge: discharge to empty')
    parser.add_argument('--timeout', type=float, default=0.0,
                        help='give up (and cancel) after this many seconds; 0 waits for ever')
    parser.add_argument('--server-timeout', type=float, default=10.0,
                        help='seconds to wait for the action server (default 10)')
    return parser.parse_args(argv)


def progress_line(percentage, state):
    """'[#####.....]  50.0 %  11.52 V  -1.50 A  discharging' (state may be None)."""
    filled = int(round(BAR_WIDTH * min(max(percentage, 0.0), 100.0) / 100.0))
    line = '[%s%s] %5.1f %%' % ('#' * filled, '.' * (BAR_WIDTH - filled), percentage)
    if state is not None:
        line += '  %6.2f V  %+6.2f A  %s' % (state.voltage, state.current,
                                             SUPPLY_STATUS.get(state.power_supply_status, 'unknown'))
    return line


class ProgressView:
    """Redraws one progress line from action feedback and battery_status."""

    def __init__(self, stream):
        self._stream = stream
        self._lock = threading.Lock()
        self._state = None
        self._last_whole = None
        self._sub = rospy.Subscriber('battery_status', BatteryState, self._on_state, queue_size=1)

    def _on_state(self, msg):
        with self._lock:
            self._state = msg

    def on_feedback(self, feedback):
        with self._lock:
            line = progress_line(feedback.battery_percentage, self._state)
            whole = int(feedback.battery_percentage)
            if self._stream.isatty():
                self._stream.write('\r' + line + '   ')
            elif whole != self._last_whole:  # a log, not a terminal: a line per percent
                self._stream.write(line + '\n')
            self._last_whole = whole
        self._stream.flush()


def main(argv=None):
    argv = rospy.myargv(sys.argv)[1:] if argv is None else argv
    args = parse_arguments(argv)
    charge = CHOICES[args.goal]
    rospy.init_node('battery_sim_client', anonymous=True, disable_signals=True)
    client = actionlib.SimpleActionClient('battery_simulator', battery_simAction)
    if not client.wait_for_server(rospy.Duration(args.server_timeout)):
        print('battery_sim_client: no action server %s after %g s'
              % (rospy.resolve_name('battery_simulator'), args.server_timeout), file=sys.stderr)
        sys.exit(3)
    view = ProgressView(sys.stdout)
    print('%s the battery...' % ('Charging' if charge else 'Discharging'))
    client.send_goal(battery_simGoal(charge_state=charge), feedback_cb=view.on_feedback)
    try:
        finished = client.wait_for_result(rospy.Duration(args.timeout))
    except KeyboardInterrupt:
        client.cancel_goal()
        client.wait_for_result(rospy.Duration(5.0))
        print('\ncancelled')
        sys.exit(130)
    if sys.stdout.isatty():
        print()
    if not finished:
        client.cancel_goal()
        client.wait_for_result(rospy.Duration(5.0))
        print('timed out after %g s; goal cancelled' % args.timeout)
        sys.exit(4)
    result = client.get_result()
    state = client.get_state()
    print('Result: %s (%s)' % (result.battery_status if result else '(none)',
                               GOAL_STATES.get(state, 'state %d' % state)))
    sys.exit(0 if state == GoalStatus.SUCCEEDED else 1)
