"""Start-up of the rclpy nodes: declared parameters checked by core/settings.py's rules, one fatal
line and a non-zero exit for a bad value, a clean end on SIGINT or SIGTERM at any moment."""
import contextlib
import signal
import sys

import rclpy
from rcl_interfaces.msg import ParameterDescriptor, ParameterType
from rclpy.executors import ExternalShutdownException

from battery_simulator.core.parameters import number_from_text
from battery_simulator.core.settings import SettingError, check_setting

EXIT_BAD_PARAMETER = 2


class StartupError(ValueError):
    """A bad start-up value; the message names it, its value and what is allowed."""


def descriptor(setting, read_only=None):
    """A ParameterDescriptor for a core Setting: any type is taken (and checked by its rule, so a
    bad value gets our one line rather than rclpy's type error), read-only unless it is live."""
    return ParameterDescriptor(
        description=setting.description, additional_constraints='must be ' + setting.allowed,
        read_only=(not setting.live) if read_only is None else read_only, dynamic_typing=True)


def declare_settings(node, settings, defaults=None):
    """Declare each Setting on ``node`` (default ``defaults[name]`` or the setting's), read and check
    it: {name: value}, or StartupError naming the parameter (its full name: node/parameter)."""
    values = {}
    for setting in settings:
        default = (defaults or {}).get(setting.name, setting.default)
        value = node.declare_parameter(setting.name, default, descriptor(setting)).value
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


def parameter_name(node, name):
    """How a fatal line names a parameter: 'time_scale of /robot1/battery_simulator'."""
    return '%s of %s' % (name, node.get_fully_qualified_name())


def exit_on_startup_error(error, logger=None):
    """One fatal line (stderr, and the node's logger if any), then exit EXIT_BAD_PARAMETER."""
    line = str(error)
    if logger is not None:
        logger.fatal(line)
    else:
        print('[FATAL] %s' % line, file=sys.stderr)
    sys.stderr.flush()
    with contextlib.suppress(Exception):
        rclpy.try_shutdown()
    sys.exit(EXIT_BAD_PARAMETER)


@contextlib.contextmanager
def ending_quietly():
    """Around a node's main: SIGINT or SIGTERM at any moment (start-up included) ends it without a traceback.

    rclpy's own handlers (installed by rclpy.init) shut the context down and then call ours, which raise
    KeyboardInterrupt in the main thread: caught here, the caller's ``finally`` saves the state."""
    def _stop(signum, frame):
        raise KeyboardInterrupt()
    signal.signal(signal.SIGINT, _stop)
    signal.signal(signal.SIGTERM, _stop)
    try:
        yield
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        with contextlib.suppress(Exception):
            rclpy.try_shutdown()


def spin(executor):
    """Spin until shutdown (rclpy's signal handlers end it); True when ended by a signal."""
    try:
        executor.spin()
    except (KeyboardInterrupt, ExternalShutdownException):
        return True
    return False
