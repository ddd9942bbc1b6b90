"""battery_sim_client.py's entry point. Its signal handlers come before the client's imports
(rospy, actionlib, numpy: about a second), so Ctrl-C then exits 130 without an import traceback."""
import signal
import sys


def _quit_while_starting(signum, frame):
    sys.exit(130)   # no goal sent yet: nothing to cancel


def main():
    signal.signal(signal.SIGINT, _quit_while_starting)
    signal.signal(signal.SIGTERM, _quit_while_starting)
    from battery_simulator.nodes import client   # replaces the handlers once it can cancel a goal
    client.main()
