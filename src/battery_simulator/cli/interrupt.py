"""Waiting that Ctrl-C and SIGTERM can end safely: the handler sets a flag, the main
thread checks it between short waits. (No ROS imports: unit-tested on its own.)"""
import threading
import time

WAIT_STEP_S = 0.1
#: a cancel (Ctrl-C, SIGTERM, --timeout) waits this long at most for the server's answer, on both ROS versions (a
#: live server answers within milliseconds; a killed one never does, and the wait is most of a Ctrl-C's 2 s: on
#: ROS 2 at 1 s a CI run's four tests on two cores took the rest; ROS 1's 5 s made a Ctrl-C take 5.7 s)
CANCEL_WAIT_S = 0.5


class Cancelled(Exception):
    """Ctrl-C or SIGTERM arrived."""


class StopRequest:
    """Notes SIGINT/SIGTERM; the main thread checks it between short waits.

    The handler only sets a flag: raising KeyboardInterrupt from it can land inside
    threading's own locks (Thread.start then fails with 'release unlocked lock').
    """

    def __init__(self):
        self.requested = False

    def handle(self, signum, frame):
        self.requested = True

    def check(self):
        if self.requested:
            raise Cancelled()


def wait_in_wall_time(wait, timeout_s, stop=None):
    """Run a blocking ``wait()`` (one that measures ROS time) in a thread; its result, or False after timeout_s.

    With a StopRequest, raises Cancelled as soon as a signal has arrived.
    """
    outcome = []
    thread = threading.Thread(target=lambda: outcome.append(wait()), daemon=True)
    thread.start()
    deadline = time.monotonic() + timeout_s
    while thread.is_alive() and time.monotonic() < deadline:
        if stop is not None:
            stop.check()
        thread.join(min(WAIT_STEP_S, max(deadline - time.monotonic(), 0.0)))
    return bool(outcome and outcome[0])
