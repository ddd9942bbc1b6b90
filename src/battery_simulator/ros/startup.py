"""Start-up parameter checks shared by the nodes: one fatal line, non-zero exit."""
import contextlib
import math
import signal
import sys
import time

import rospy


class StartupError(ValueError):
    """A bad parameter at start-up; the message names it, its value and what is allowed."""


def is_number(value):
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def number_from_text(value):
    """A numeric string as a float ('1e9', ' 22 '); anything else as it is.

    roslaunch hands some numbers over as text (``time_scale:=1e9`` among them).
    """
    if isinstance(value, str):
        try:
            return float(value.strip())
        except ValueError:
            pass
    return value


def checked_param(name, default, check, allowed):
    """rospy.get_param(name, default), raising StartupError unless ``check`` accepts it.

    A numeric string is read as the number it spells where the default is a number.
    """
    value = rospy.get_param(name, default)
    if is_number(default):
        value = number_from_text(value)
    if not check(value):
        raise StartupError('parameter %s = %r is invalid: must be %s'
                           % (rospy.resolve_name(name), value, allowed))
    return value


def wait_for_rosout(timeout_s=2.0):
    """Wait (bounded, wall time) until /rosout listens, so that start-up lines reach rqt_console and tests.

    rospy's /rosout publisher is latched with no queue for a late subscriber:
    lines logged before rosout connects are lost but for the last.
    """
    from rospy.impl import rosout   # rospy's own publisher of /rosout
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline and not rospy.is_shutdown():
        publisher = rosout._rosout_pub
        if publisher is not None and publisher.get_num_connections() > 0:
            return
        time.sleep(0.02)


@contextlib.contextmanager
def signals_held():
    """Hold SIGINT and SIGTERM while a node starts; deliver them once it is up.

    rospy's handler makes XML-RPC calls to the master; run while the main
    thread is inside one (start-up is full of them) it waits on the lock that
    thread holds, and the node hangs for ever. Threads started meanwhile
    inherit the mask, so a held signal reaches the main thread at a safe point.
    """
    held = {signal.SIGINT, signal.SIGTERM}
    previous = signal.pthread_sigmask(signal.SIG_BLOCK, held)
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, previous)


def init_node(name, read_settings):
    """rospy.init_node(name), then read_settings(): its settings, or one fatal line and exit 1."""
    rospy.init_node(name)
    try:
        return read_settings()
    except StartupError as error:
        exit_on_startup_error(error)


def exit_on_startup_error(error):
    """Log one fatal line and exit 1 (roslaunch shows the node as died)."""
    rospy.logfatal('%s', error)
    sys.stderr.flush()
    sys.exit(1)
