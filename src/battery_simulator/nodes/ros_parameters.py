"""Start-up parameter checks shared by the nodes: one fatal line, non-zero exit."""
import math
import sys

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


def exit_on_startup_error(error):
    """Log one fatal line and exit 1 (roslaunch shows the node as died)."""
    rospy.logfatal('%s', error)
    sys.stderr.flush()
    sys.exit(1)
