"""battery_sim_client.py's command line. The arguments are read and the signal handlers set
before the client's imports (rospy, actionlib, numpy: about a second), so a usage error or
--help answers at once, and Ctrl-C while starting exits 130 without an import traceback."""
import argparse
import math
import signal
import sys
from collections import namedtuple

from battery_simulator.cli.interrupt import StopRequest

CHOICES = {'1': True, 'charge': True, '0': False, 'discharge': False}
ROS_REMAP = ':='   # name:=value arguments are roslaunch's, not ours (as rospy.myargv drops them)
#: what the runners (ros1/client.py, ros2/client.py) take: plain values, no parser
GoalRequest = namedtuple('GoalRequest', 'charge timeout server_timeout')


def _seconds(minimum_exclusive):
    def parse(text):
        try:
            value = float(text)
        except ValueError:
            value = math.nan
        if not (math.isfinite(value) and (value > 0 if minimum_exclusive else value >= 0)):
            raise argparse.ArgumentTypeError('%s is not a number of seconds %s 0' % (
                text, '>' if minimum_exclusive else '>='))
        return value
    return parse


def parse_arguments(argv):
    parser = argparse.ArgumentParser(
        prog='battery_sim_client.py', description='Charge or discharge the simulated battery. '
        'Timeouts are wall-clock seconds, also under /use_sim_time.')
    parser.add_argument('goal', choices=sorted(CHOICES), metavar='{1,0,charge,discharge}',
                        help='1 or charge: charge to full; 0 or discharge: discharge to empty')
    parser.add_argument('--timeout', type=_seconds(False), default=0.0,
                        help='give up (and cancel) after this many seconds; 0 waits for ever')
    parser.add_argument('--server-timeout', type=_seconds(True), default=10.0,
                        help='seconds to wait for the ROS master and the action server (default 10)')
    return parser.parse_args(argv)


def goal_request(argv):
    """The GoalRequest of a command line (argparse exits 2 with its usage on a bad one)."""
    args = parse_arguments(argv)
    return GoalRequest(CHOICES[args.goal], args.timeout, args.server_timeout)


def main(argv=None):
    stop = StopRequest()

    def quit_while_starting(signum, frame):
        # noted first: an exit raised while a finaliser runs is swallowed, and run() then sees the note before it
        # sends anything
        stop.handle(signum, frame)
        sys.exit(130)   # no goal sent yet: nothing to cancel

    def unraisable(report, report_others=sys.unraisablehook):
        if not (stop.requested and isinstance(report.exc_value, SystemExit)):   # ours: no "Exception ignored" trace
            report_others(report)
    sys.unraisablehook = unraisable
    signal.signal(signal.SIGINT, quit_while_starting)
    signal.signal(signal.SIGTERM, quit_while_starting)
    argv = sys.argv[1:] if argv is None else argv
    request = goal_request([arg for arg in argv if ROS_REMAP not in arg])
    from battery_simulator.ros1 import client   # rospy's imports after the arguments; it replaces the handlers
    client.run(request, stop)
