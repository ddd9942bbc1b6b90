"""Start-up parameter checks shared by the nodes: one fatal line, non-zero exit."""
import contextlib
import os
import signal
import sys
import time

import rosgraph
import rospy

from battery_simulator.core import ros_names
from battery_simulator.core.node_settings import EXIT_STARTUP_ERROR
from battery_simulator.core.parameter_rules import is_number, number_from_text, refusal
from battery_simulator.core.state_file import StateFileError, check_state_file
from battery_simulator.node_signals import end_nodes_on_signals

FATAL_FLUSH_S = 0.3   # how long a dying node gives its last line to reach /rosout


class StartupError(ValueError):
    """A bad parameter at start-up; the message names it, its value and what is allowed."""


def checked_param(name, default, check, allowed):
    """rospy.get_param(name, default), raising StartupError unless ``check`` accepts it.

    A numeric string is read as the number it spells where the default is a number.
    """
    value = rospy.get_param(name, default)
    if is_number(default):
        value = number_from_text(value)
    if not check(value):
        raise StartupError(refusal(rospy.resolve_name(name), value, 'must be ' + allowed))
    return value


def read_private_settings(settings):
    """{name: value} of core/node_settings.py Settings read as private parameters (``~name``), checked."""
    return {setting.name: checked_param('~' + setting.name, setting.default, setting.check, setting.allowed)
            for setting in settings}


def check_state_file_param(path, name='~state_file', fleet=False):
    """StartupError (one line naming the parameter) for a ``path`` that exists and is not a state file (it is
    never written over), that cannot be written or that another battery holds; '' (no file) passes. This
    node holds it from now on."""
    if path:
        try:
            check_state_file(path, fleet, holder=rospy.get_name())
        except StateFileError as error:
            raise StartupError(refusal(rospy.resolve_name(name), path, error)) from None


_clock_publishers = (-float('inf'), [])   # (monotonic time, names) of the last lookup


def clock_publishers(period_s=10.0):
    """The nodes that publish /clock (looked up at the master at most every ``period_s``, on demand:
    after a clock jump, never at every update)."""
    global _clock_publishers
    looked_up_at, names = _clock_publishers
    if time.monotonic() - looked_up_at >= period_s:
        try:
            publishers, _, _ = rosgraph.Master(rospy.get_name()).getSystemState()
            names = next((nodes for topic, nodes in publishers if topic == ros_names.CLOCK), [])
        except (OSError, rosgraph.MasterException):
            names = []
        _clock_publishers = (time.monotonic(), names)
    return names


def batteries_served_elsewhere(namespaces, service=ros_names.SET_STATE):
    """{namespace: node} for each of ``namespaces`` ('/robot1/') whose battery another node already serves
    (its ``service`` is registered at the master by a node other than this one: a respawned node has
    this node's name and takes its place). One master call, at start-up."""
    services = rosgraph.Master(rospy.get_name()).getSystemState()[2]
    providers = {name: nodes for name, nodes in services}
    me = rospy.get_name()
    found = {}
    for namespace in namespaces:
        others = [node for node in providers.get(namespace + service, []) if node != me]
        if others:
            found[namespace] = others[0]
    return found


def check_one_battery_per_name(namespaces):
    """StartupError naming the first robot another node already serves (exactly one model per name)."""
    taken = batteries_served_elsewhere(namespaces)
    if taken:
        namespace = sorted(taken)[0]
        raise StartupError('robot %s is already served by %s: exactly one battery model per robot name%s' % (
            namespace.strip('/') or '/', taken[namespace],
            '' if len(taken) == 1 else ' (%d of these robots are: %s)' % (
                len(taken), ', '.join(n.strip('/') for n in sorted(taken)))))


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
    """Around a node's start-up: SIGINT and SIGTERM end it at any moment (node_signals.py: rospy keeps
    out of signal handling, since its handler would call the master from inside the signal)."""
    end_nodes_on_signals()
    yield


def init_node(name, read_settings):
    """rospy.init_node(name), then read_settings(): its settings, or one fatal line and exit 2 (EXIT_STARTUP_ERROR).
    SIGINT and SIGTERM are node_signals.py's (rospy's handler can hang a node that is starting)."""
    end_nodes_on_signals()
    try:
        rospy.init_node(name, disable_signals=True)
    except OverflowError:   # rospy sets the command line's _param:=value on the master (XML-RPC: 32-bit)
        too_large = [argument for argument in sys.argv[1:] if argument.startswith('_') and ':=' in argument
                     and argument.split(':=', 1)[1].strip().lstrip('-').isdigit()
                     and abs(int(argument.split(':=', 1)[1])) > 2 ** 31 - 1]
        print('[FATAL] %s: parameter %s is invalid: an integer beyond 32 bits, which the parameter server cannot '
              'hold (give it as a float, e.g. 5e9)' % (name, ', '.join(too_large) or '(on the command line)'),
              file=sys.stderr)
        sys.exit(EXIT_STARTUP_ERROR)
    try:
        return read_settings()
    except StartupError as error:
        exit_on_startup_error(error)


def exit_on_startup_error(error, stop_launch=True):
    """Log one fatal line, stop the launch that started this node (unless ``stop_launch`` is false), and exit 2 (EXIT_STARTUP_ERROR, as on ROS 2).

    A respawning node (the server) would otherwise be started again every
    respawn_delay and print the same line for ever: a bad value does not go
    away by itself. So a node started by roslaunch asks roslaunch to shut
    down (SIGINT, as Ctrl-C does); respawn still brings back a node that
    crashed. Under rosrun or rostest the parent is left alone.
    """
    launcher = os.getppid()
    stop_launch = stop_launch and _is_roslaunch(launcher)
    rospy.logfatal('%s%s', error, '; stopping the launch' if stop_launch else '')
    sys.stderr.flush()
    if stop_launch:
        os.kill(launcher, signal.SIGINT)
    sys.exit(EXIT_STARTUP_ERROR)


def _is_roslaunch(pid):
    try:
        with open('/proc/%d/cmdline' % pid, 'rb') as stream:
            arguments = stream.read().split(b'\0')
    except OSError:
        return False
    return any(os.path.basename(argument) == b'roslaunch' for argument in arguments[:2])


@contextlib.contextmanager
def ending_the_node_on_error(what):
    """Run a node's worker: an exception that escapes it ends the whole node with one FATAL line and exit 1.

    A worker thread that dies leaves a process that looks alive (respawn never
    helps) but serves a frozen state; ended, it is respawned and resumes from
    the saved state.
    """
    try:
        yield
    except Exception as error:   # noqa: B902 (anything: the node cannot go on without its worker)
        rospy.logfatal('%s failed (%s: %s): ending the node; a respawn resumes from the saved state',
                       what, type(error).__name__, error)
        time.sleep(FATAL_FLUSH_S)   # let the line reach /rosout
        sys.stderr.flush()
        os._exit(1)
