#!/usr/bin/python3
"""Sends a charge (1) or discharge (0) goal to battery_simulator and shows progress."""
import signal
import sys


def _quit_while_starting(signum, frame):
    sys.exit(130)   # no goal sent yet: nothing to cancel, and no import traceback


signal.signal(signal.SIGINT, _quit_while_starting)
signal.signal(signal.SIGTERM, _quit_while_starting)

from battery_simulator.nodes.client import main  # noqa: E402  (the handlers first: the imports take a second)

main()
