"""The start-up settings of the battery nodes, with their rules, written once (no ROS import).

Both front ends read them: the rospy nodes as private parameters
(``~time_scale``), the rclpy nodes as declared parameters (``time_scale``,
with a descriptor built from ``description`` and ``allowed``). A bad value
stops a node with one line: ``parameter NAME = VALUE is invalid: must be ALLOWED``.
"""
import re
from collections import namedtuple

from battery_simulator.core.config_files import default_config_path, load_yaml, with_gauge_config
from battery_simulator.core.parameter_rules import ParameterError, is_number, refusal


class SettingError(ValueError):
    """A bad start-up value; the message names it, its value and what is allowed."""


def is_mode_value(value):
    """A mode value (ROS 1's MyRobot/BatteryStatus, ROS 2's ``charging``): true / false, or 1 / 0."""
    return value is not None and not isinstance(value, str) and value in (True, False, 0, 1)


#: ``bounds``: (lowest, highest) a number may be, for a ROS 2 descriptor's floating_point_range (None: no range to
#: state; ``check`` stays the rule, an open end included)
Setting = namedtuple('Setting', 'name default check allowed description live bounds', defaults=(None,))


def _fraction(value):
    return is_number(value) and 0.0 <= value <= 1.0


#: the largest time_scale: at the default 10 Hz one update then spans 1000 s of battery (a quarter of a
#: discharge); beyond it a charge, a discharge or the pack's whole life would pass in a few updates, with
#: no feedback, alarm or dock in between
#: the exit status of a node refused at start-up (a bad value, a duplicate battery), on both ROS versions: the
#: launch files respawn a process that crashed, never one that ended so
EXIT_STARTUP_ERROR = 2
MAX_TIME_SCALE = 10000.0


def _rate(value):
    return is_number(value) and 0 < value <= 1000


#: the mode's values, as both front ends say them (ROS 1's MyRobot/BatteryStatus takes 1 / 0)
MODE_ALLOWED = "true or false (or 1 / 0, as ROS 1's MyRobot/BatteryStatus)"

#: the battery's own settings (ros1/battery_sim.py, ROS 2's battery_simulator node, the fleet hosts)
BATTERY_SETTINGS = (
    Setting('config', str(default_config_path()), lambda v: isinstance(v, str) and v != '',
            'a path to a YAML file', 'battery config: a preset plus overrides (YAML)', False),
    Setting('time_scale', 22.0, lambda v: is_number(v) and 0 < v <= MAX_TIME_SCALE,
            'a number in (0, %g] (one update of a faster battery would span more than a quarter of a discharge)'
            % MAX_TIME_SCALE,
            'simulated seconds per wall second (ignored under use_sim_time)', True, (0.0, MAX_TIME_SCALE)),
    Setting('update_rate', 10.0, _rate, 'a number in (0, 1000] Hz', 'model updates per second', False, (0.0, 1000.0)),
    Setting('initial_percentage', 100.0, lambda v: is_number(v) and 0 <= v <= 100, 'a number in [0, 100]',
            'charge at start, %', False, (0.0, 100.0)),
    Setting('charging', False, is_mode_value, MODE_ALLOWED,
            'initial mode: true charges, false discharges', False),
    Setting('state_file', '', lambda v: isinstance(v, str), 'a file path (or empty)',
            'JSON file the state is saved to and resumed from (empty: none)', False),
    Setting('max_time_jump', 3600.0, lambda v: is_number(v) and v > 0, 'a number > 0 s',
            'under use_sim_time: a forward jump of ROS time larger than this between two updates restarts '
            'the time base (nothing drained)', False),
)
#: a single battery's gauge from another file (battery_sim_server.py, ROS 2's battery_simulator node; a
#: fleet's robots take theirs from their configs: gauge: {preset: impedance_track})
GAUGE_CONFIG = Setting('gauge_config', '', lambda v: isinstance(v, str), 'a path to a YAML file (or empty)',
                       "a YAML file whose gauge section replaces the config's (a gauge preset, "
                       'config/presets/gauge_impedance_track.yaml; empty: the config\'s own gauge)', False)
#: a ROS name, relative or absolute, of letters, digits, underscores and slashes (ROS 1 and ROS 2 alike)
_TOPIC_NAME = re.compile(r'^/?[A-Za-z][A-Za-z0-9_]*(/[A-Za-z][A-Za-z0-9_]*)*$')


def is_topic_name(value):
    """A topic name both ROS 1 and ROS 2 accept (rclpy raises on one it cannot resolve)."""
    return isinstance(value, str) and _TOPIC_NAME.match(value) is not None


def _topic_or_empty(value):
    return value == '' or is_topic_name(value)


#: battery_state_pub's settings
PUBLISHER_SETTINGS = (
    Setting('rate', 1.0, _rate, 'a number in (0, 1000] Hz', 'battery_status publications per second', False,
            (0.0, 1000.0)),
    Setting('frame_id', 'battery', lambda v: isinstance(v, str), 'a string', 'header.frame_id', False),
    Setting('stale_timeout', 3.0, lambda v: is_number(v) and v > 0, 'a number > 0 s',
            'warn after this long without an update from the battery, s', False),
    Setting('low_percentage', 0.20, _fraction, 'a fraction in [0, 1]', 'battery_low below this (0-1)', False,
            (0.0, 1.0)),
    Setting('critical_percentage', 0.05, _fraction, 'a fraction in [0, 1]',
            'battery_critical below this (0-1, at most low_percentage)', False, (0.0, 1.0)),
    Setting('hysteresis', 0.05, _fraction, 'a fraction in [0, 1]',
            'an event clears above its threshold plus this (0-1)', False, (0.0, 1.0)),
    Setting('battery_state_topic', 'battery_state', _topic_or_empty, 'a topic name (or empty: none)',
            'the same BatteryState also on this topic, relative to the robot (opennav_docking reads '
            'battery_state; empty: battery_status only)', False),
)


def setting(name):
    """The Setting named ``name`` (battery or publisher)."""
    return next(s for s in BATTERY_SETTINGS + PUBLISHER_SETTINGS if s.name == name)


def check_setting(setting, value, shown_name=None):
    """``value`` if ``setting`` allows it, else SettingError naming ``shown_name`` (default its name)."""
    if not setting.check(value):
        raise SettingError(refusal(shown_name or setting.name, value, 'must be ' + setting.allowed))
    return value


def load_battery_config(path, gauge_config='', shown_name=lambda name: name):
    """The battery parameters of the YAML file ``path`` with the gauge of ``gauge_config`` (a gauge preset's
    file) if given; SettingError naming the parameter as ``shown_name('config')`` / ``('gauge_config')``."""
    try:
        params = load_yaml(path)
    except ParameterError as error:
        raise SettingError(refusal(shown_name('config'), path, error)) from None
    try:
        return with_gauge_config(params, gauge_config)
    except ParameterError as error:
        raise SettingError('parameter %s is invalid: %s' % (shown_name('gauge_config'), error)) from None


def check_publisher_settings(settings, shown_name=lambda name: name, other_name=lambda name: name):
    """The rules between publisher settings: critical at most low. SettingError otherwise (naming the
    bad one as ``shown_name(name)`` and the one it breaks a rule with as ``other_name(name)``)."""
    if settings['critical_percentage'] > settings['low_percentage']:
        raise SettingError(refusal(shown_name('critical_percentage'), settings['critical_percentage'],
                                   'must be at most %s (%g)' % (other_name('low_percentage'), settings['low_percentage'])))
    return settings
