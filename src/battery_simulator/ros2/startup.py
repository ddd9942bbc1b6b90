"""Start-up of the rclpy nodes: declared parameters checked by core/node_settings.py's rules, one fatal
line and a non-zero exit for a bad value, a clean end on SIGINT or SIGTERM at any moment.

rclpy's own signal handlers are not installed (``init``): they shut the context down before any code of
ours runs, so a goal could not be ended nor its result sent ("feedback publisher is invalid"). Here a
signal during start-up ends the process (nothing to save yet); once running (``run``) it stops the
spinning, the node's ``finish()`` ends its goals (aborted, "server shutting down") and saves, the executor
runs until their results are sent (at most FINISH_S), and only then is the context shut down: exit 0.
"""
import contextlib
import os
import re
import signal
import sys
import threading
import time

import rclpy
from rclpy.clock import Clock, ClockType
from rclpy.impl.implementation_singleton import rclpy_implementation
from rcl_interfaces.msg import FloatingPointRange, ParameterDescriptor, ParameterType, SetParametersResult
from rclpy.exceptions import InvalidParameterValueException
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.node import Node
from rclpy.signals import SignalHandlerOptions
from rclpy.task import Future

from battery_simulator.core.node_settings import EXIT_STARTUP_ERROR, SettingError, check_setting
from battery_simulator.core.parameter_rules import number_from_text, refusal
from battery_simulator.ros2.rcl_args import rcl_problem

#: after a stop signal, the executor runs this long at most for the goals' results to be sent
FINISH_S = 1.5
#: ... and this long after they have gone, so that DDS delivers them before the process ends
LINGER_S = 0.3
#: the process ends at most this long after SIGINT or SIGTERM (the contract allows 2 s; the rest is margin)
STOP_S = 1.5
#: a process refused at start-up ends at most this long after its line (rcl's teardown cut short)
STARTUP_EXIT_S = 1.0


def own_node(name, namespace, **options):
    """A Node ``name`` in ``namespace`` whatever the process's global remaps. ``ros2 launch`` gives every node
    it starts ``-r __node:=NAME -r __ns:=NS``, and a global remap applies to every node of a process: a
    fleet's robots (or battery_sim's battery_state_pub) would all take the host's name and namespace. Remaps of
    the node's own (``cli_args``) come before the global ones; parameter overrides still apply."""
    return Node(name, namespace=namespace, cli_args=['--ros-args', '-r', '__node:=' + name, '-r', '__ns:=' + namespace],
                **options)


def child_namespace(parent, name):
    """The namespace ``name`` under ``parent``: ('/', 'robot1') -> '/robot1'; ('/site', 'robot1') -> '/site/robot1'."""
    return parent.rstrip('/') + '/' + name.strip('/')


def steady_clock():
    """Timers on wall time: a paused or jumping /clock must not stop updates, publications or scans."""
    return Clock(clock_type=ClockType.STEADY_TIME)


class StartupError(ValueError):
    """A bad start-up value; the message names it, its value and what is allowed."""


def descriptor(setting, read_only=None):
    """A ParameterDescriptor for a core Setting: any type is taken (and checked by its rule, so a
    bad value gets our one line rather than rclpy's type error), read-only unless it is live."""
    ranges = [] if setting.bounds is None else [FloatingPointRange(from_value=float(setting.bounds[0]),
                                                                   to_value=float(setting.bounds[1]), step=0.0)]
    return ParameterDescriptor(
        description=setting.description, additional_constraints='must be ' + setting.allowed,
        read_only=(not setting.live) if read_only is None else read_only, dynamic_typing=True,
        floating_point_range=ranges)


def declare_settings(node, settings, defaults=None):
    """Declare each Setting on ``node`` (default ``defaults[name]`` or the setting's), read and check
    it: {name: value}, or StartupError naming the parameter (its full name: node/parameter)."""
    values = {}
    for setting in settings:
        default = (defaults or {}).get(setting.name, setting.default)
        try:
            value = node.declare_parameter(setting.name, default, descriptor(setting)).value
        except InvalidParameterValueException:   # outside the descriptor's range: the rule's one line, not rclpy's
            raise StartupError(refusal(parameter_name(node, setting.name), given_value(node, setting.name),
                                       'must be ' + setting.allowed)) from None
        if isinstance(setting.default, (int, float)) and not isinstance(setting.default, bool):
            value = number_from_text(value)
        if isinstance(setting.default, bool) and value in (0, 1) and not isinstance(value, bool):
            value = bool(value)
        try:
            values[setting.name] = check_setting(setting, value, parameter_name(node, setting.name))
        except SettingError as error:
            raise StartupError(str(error)) from None
    return values


def declare_bool(node, name, default, description, read_only=False):
    """A bool parameter (typed: ROS 2 itself refuses another type with a reason)."""
    return node.declare_parameter(name, default, ParameterDescriptor(
        type=ParameterType.PARAMETER_BOOL, description=description, read_only=read_only)).value


#: what a parameter of a fixed type takes, in a refusal
TYPE_WORDS = {ParameterType.PARAMETER_BOOL: 'true or false', ParameterType.PARAMETER_INTEGER: 'an integer',
              ParameterType.PARAMETER_DOUBLE: 'a number', ParameterType.PARAMETER_STRING: 'a string',
              ParameterType.PARAMETER_BYTE_ARRAY: 'a byte array', ParameterType.PARAMETER_BOOL_ARRAY: 'a bool array',
              ParameterType.PARAMETER_INTEGER_ARRAY: 'an integer array',
              ParameterType.PARAMETER_DOUBLE_ARRAY: 'a number array',
              ParameterType.PARAMETER_STRING_ARRAY: 'a string array'}


def explain_parameter_refusals(node):
    """rclpy refuses a run-time set of an undeclared, read-only or mistyped parameter with texts of its own
    ("Invalid access to undeclared parameter(s): []", "Wrong parameter type, expected '1' got '4'"): the
    node's set_parameters services answer with the package's one-line reason instead, naming the parameter
    and what is allowed (its parameters; a start-up value; the type). Anything else goes on as before."""
    original = node.set_parameters_atomically   # both services call it (set_parameters: one at a time)

    def checked(parameters):
        reason = parameter_refusal(node, parameters)
        return SetParametersResult(successful=False, reason=reason) if reason else original(parameters)
    node.set_parameters_atomically = checked


def parameter_refusal(node, parameters):
    """The reason a run-time set of ``parameters`` is refused before any rule of ours sees it, or None."""
    for parameter in parameters:
        if not node.has_parameter(parameter.name):
            return '%s is not a parameter of %s; its parameters: %s' % (
                parameter.name, node.get_fully_qualified_name(), ', '.join(sorted(node.list_parameters([], 0).names)))
        described = node.describe_parameter(parameter.name)
        if described.read_only:
            return '%s of %s is read at start only: start the node again with -p %s:=VALUE' % (
                parameter.name, node.get_fully_qualified_name(), parameter.name)
        value = parameter.value
        if described.floating_point_range and isinstance(value, float) and not (
                described.floating_point_range[0].from_value <= value <= described.floating_point_range[0].to_value):
            return '%s; keeping %s' % (refusal(parameter.name, value, described.additional_constraints),
                                       node.get_parameter(parameter.name).value)
        if not described.dynamic_typing and parameter.type_.value != described.type and \
                described.type in TYPE_WORDS:
            return refusal(parameter.name, parameter.value, 'must be ' + TYPE_WORDS[described.type])
    return None


def was_given(node, name):
    """Whether ``name`` was given on the command line (a parameter override), not defaulted."""
    return name in node._parameter_overrides   # rclpy keeps no public view of the overrides


def given_value(node, name):
    """The value ``name`` was given on the command line (None: not given)."""
    return node._parameter_overrides[name].value if was_given(node, name) else None


def parameter_name(node, name):
    """How a fatal line names a parameter: 'time_scale of /robot1/battery_simulator'."""
    return '%s of %s' % (name, node.get_fully_qualified_name())


def exit_on_startup_error(error, logger=None):
    """One fatal line (stderr, and the node's logger if any), then exit EXIT_STARTUP_ERROR within
    STARTUP_EXIT_S: left to the interpreter, rcl's teardown kept a refused duplicate running over 15 s on a busy
    machine (a fresh-clone CI run)."""
    line = str(error)
    if logger is not None:
        logger.fatal(line)
    else:
        print('[FATAL] %s' % line, file=sys.stderr)
    sys.stderr.flush()
    end_process(EXIT_STARTUP_ERROR, time.monotonic() + STARTUP_EXIT_S)


def init(args=None):
    """rclpy.init without rclpy's signal handlers (see the module's docstring). ROS arguments rcl cannot
    read (``-p config:=``, an empty value) end the process with one line naming the parameter, not rcl's
    traceback."""
    arguments = sys.argv if args is None else args
    for before, argument in zip(arguments, arguments[1:]):   # before rcl, which logs a line of its own
        if before in ('-p', '--param') and re.fullmatch(r'[^:=]+:=', argument):
            exit_on_startup_error(StartupError(empty_parameter_refusal(argument[:-2])))
    try:
        rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)
    except (RuntimeError, rclpy_implementation.RCLError) as error:   # rcl cannot read the ROS arguments
        empty = re.search(r"parameter override rule: '-p ([^:']+):='", str(error))
        exit_on_startup_error(StartupError(empty_parameter_refusal(empty.group(1)) if empty else
                                           'bad --ros-args: %s' % rcl_problem(error)))


def empty_parameter_refusal(name):
    """The one line for ``-p name:=`` (rcl reads no empty value)."""
    return ('parameter %s has no value (-p %s:= with nothing after it): give one (-p %s:=VALUE), or leave it '
            'out for its default' % (name, name, name))


@contextlib.contextmanager
def ending_quietly():
    """Around a node's main: SIGINT or SIGTERM during start-up ends it without a traceback (a
    KeyboardInterrupt in the main thread, caught here); ``run`` takes over once the node runs."""
    def _stop(signum, frame):
        raise KeyboardInterrupt()
    signal.signal(signal.SIGINT, _stop)
    signal.signal(signal.SIGTERM, _stop)
    try:
        yield
    except (KeyboardInterrupt, ExternalShutdownException):
        end_process(0, time.monotonic() + STOP_S - 0.3)   # nothing to save yet
    finally:
        with contextlib.suppress(Exception):
            rclpy.try_shutdown()


def _stop_future(executor):
    """A Future done at the first SIGINT or SIGTERM (its result: the moment, monotonic). The signal's byte
    arrives on a pipe (Python's wakeup fd, written in the C handler) read by a thread: it wakes the executor at
    once, which the main thread, blocked in rcl's wait, could not do for itself."""
    stop = Future()
    read_fd, write_fd = os.pipe()
    os.set_blocking(write_fd, False)
    signal.set_wakeup_fd(write_fd)

    def _noted(signum, frame):   # the byte on the pipe is the notice
        pass
    signal.signal(signal.SIGINT, _noted)
    signal.signal(signal.SIGTERM, _noted)

    def _watch():
        with contextlib.suppress(OSError):
            os.read(read_fd, 1)
        if not stop.done():
            stop.set_result(time.monotonic())
        executor.wake()
    threading.Thread(target=_watch, name='stop_signal', daemon=True).start()
    return stop


def run(executor, finish, claim=None):
    """Spin until SIGINT or SIGTERM (or until ``claim`` is lost); then ``finish()`` (ends the goals, saves;
    returns a function telling whether every goal's result has gone) and spin until it is true, at most
    FINISH_S; then the process ends (``end_process``) within STOP_S of the signal: exit 0, or
    EXIT_STARTUP_ERROR for a lost claim. Never returns."""
    stop = _stop_future(executor)
    if claim is not None:
        claim.on_lost = lambda: stop.done() or stop.set_result(time.monotonic()) or executor.wake()
    try:
        executor.spin_until_future_complete(stop)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    stopped_at = stop.result() if stop.done() else time.monotonic()
    finished = finish()
    deadline = stopped_at + FINISH_S
    with contextlib.suppress(Exception):
        if not finished():   # goals were running: their results go out (reliable: acknowledged) before the end
            while rclpy.ok() and not finished() and time.monotonic() < deadline:
                executor.spin_once(timeout_sec=0.05)
            linger = min(deadline, time.monotonic() + LINGER_S)
            while rclpy.ok() and time.monotonic() < linger:
                executor.spin_once(timeout_sec=0.05)
    if claim is not None:
        claim.release()
    end_process(EXIT_STARTUP_ERROR if claim is not None and claim.lost is not None else 0, stopped_at + STOP_S)


#: what end_process does before os._exit (which runs no atexit handler nor finally block): e.g. removing a file
#: the process wrote for itself
_AT_END = []


def at_end(action):
    """Have ``action()`` run when the process ends through end_process (a start-up error included)."""
    _AT_END.append(action)


def end_process(code, by, threads_in_rcl=()):
    """End the process, its work done (goals ended, state saved): the rcl context shut down in a thread (every
    node, publisher and service destroyed, so that the graph of other processes drops them at once; about 16 ms a
    robot of a fleet, each endpoint's removal announced by DDS), the logs flushed, and ``os._exit(code)`` once
    that is done or at ``by`` (monotonic), whichever comes first: a fleet larger than that allows leaves the rest
    to its peers' lease (about 20 s). Left to the interpreter, the teardown took 5.5 s at 100 robots (15 s on a
    busy machine). ``threads_in_rcl``: threads told to stop that may still wait in rcl; the context is shut
    down only once they have ended (joined until ``by``; shut down under a wait, it crashes the process)."""
    import logging
    done = threading.Event()

    def _shut_down():
        with contextlib.suppress(Exception):
            rclpy.try_shutdown()
        done.set()
    for thread in threads_in_rcl:
        thread.join(max(0.0, by - time.monotonic()))
    if not any(thread.is_alive() for thread in threads_in_rcl):
        threading.Thread(target=_shut_down, name='shutdown', daemon=True).start()
        done.wait(max(0.0, by - time.monotonic()))
    with contextlib.suppress(Exception):
        logging.shutdown()
    for action in _AT_END:
        with contextlib.suppress(Exception):
            action()
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(Exception):
            stream.flush()
    os._exit(code)


# -- a loop node's main (fake_base, dock_contact, cmd_vel_gate, patrol_and_dock, sim_clock) -------------

def read_settings(node, settings, defaults=None):
    """The declared, checked settings of ``node``; one fatal line and exit 2 for a bad one."""
    try:
        return declare_settings(node, settings, defaults)
    except StartupError as error:
        exit_on_startup_error(error, node.get_logger())


def nothing_to_finish():
    """``run``'s finish for a node with nothing to save: done at once."""
    return lambda: True


def run_node(name, settings, make, args=None, defaults=None):
    """A node's main: ``init``, Node ``name``, its settings (``defaults`` {name: value} over theirs),
    ``make(node, **settings)``, spin until SIGINT or SIGTERM (``run``; then the role's ``finish()`` if it
    has one)."""
    with ending_quietly():
        init(args)
        node = Node(name)
        role = make(node, **read_settings(node, settings, defaults))
        executor = SingleThreadedExecutor()
        executor.add_node(node)
        run(executor, getattr(role, 'finish', nothing_to_finish))
