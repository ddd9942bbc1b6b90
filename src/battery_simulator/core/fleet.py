"""The robots a fleet host runs: names, configs, levels (no rospy).

``~robots`` is either a count N (names ``<prefix><first + k>``) or a list of
``{name, config, initial_percentage, charging}`` with every key but ``name``
optional. What a robot does not set comes from the host's defaults; with a
count and no fleet-wide initial percentage the levels are staggered as
fleet.launch always did: 100, 95, 90, ..., wrapping at 20.
"""
import math
import re
from dataclasses import dataclass, replace

from battery_simulator.core.node_settings import Setting
from battery_simulator.core.parameter_rules import is_number

#: a ROS graph name segment: a letter, then letters, digits and underscores
_NAME = re.compile(r'^[A-Za-z][A-Za-z0-9_]*$')
ROBOT_KEYS = ('name', 'config', 'initial_percentage', 'charging')
MAX_ROBOTS = 10000


class FleetError(ValueError):
    """A bad robot entry; the message names the robot and the key."""


@dataclass(frozen=True)
class RobotSpec:
    name: str
    config: str
    initial_percentage: float
    charging: bool


def staggered_percentage(index):
    """The level of the ``index``-th robot of a counted fleet: 100, 95, ..., 20, then 100 again."""
    return 100.0 - (5 * index) % 85


def robot_specs(robots, prefix='robot', first=0, config='', initial_percentage=None, charging=False):
    """The RobotSpec of every robot ``~robots`` asks for, in order; FleetError for a bad entry."""
    if isinstance(robots, int) and not isinstance(robots, bool):
        if not 1 <= robots <= MAX_ROBOTS:
            raise FleetError('~robots = %r is invalid: must be a count in [1, %d] or a list of robots'
                             % (robots, MAX_ROBOTS))
        if not _NAME.match('%s%d' % (prefix, first)):
            raise FleetError('~prefix = %r is invalid: robot names must start with a letter and hold only '
                             'letters, digits and _' % (prefix,))
        return [RobotSpec('%s%d' % (prefix, first + k), config,
                          staggered_percentage(first + k) if initial_percentage is None else initial_percentage,
                          charging) for k in range(robots)]
    if not isinstance(robots, list) or not robots:
        raise FleetError('~robots = %r is invalid: must be a count in [1, %d] or a non-empty list of '
                         '{name, config, initial_percentage, charging}' % (robots, MAX_ROBOTS))
    specs, seen = [], set()
    for index, entry in enumerate(robots):
        specs.append(_robot_entry(index, entry, seen, config, initial_percentage, charging))
    return specs


def _robot_entry(index, entry, seen, config, initial_percentage, charging):
    if not isinstance(entry, dict):
        raise FleetError('~robots[%d] = %r is invalid: must be a mapping with at least a name' % (index, entry))
    name = entry.get('name')
    if not isinstance(name, str) or not _NAME.match(name):
        raise FleetError('~robots[%d] name = %r is invalid: must start with a letter and hold only letters, '
                         'digits and _' % (index, name))
    if name in seen:
        raise FleetError('robot %s: name is invalid: another robot has it already' % name)
    seen.add(name)
    unknown = sorted(str(key) for key in entry if key not in ROBOT_KEYS)
    if unknown:
        raise FleetError('robot %s: key %s is unknown (known: %s)' % (name, unknown[0], ', '.join(ROBOT_KEYS)))
    robot_config = entry.get('config', config)
    if not isinstance(robot_config, str):
        raise FleetError('robot %s: config = %r is invalid: must be a path to a YAML file' % (name, robot_config))
    level = entry.get('initial_percentage', 100.0 if initial_percentage is None else initial_percentage)
    if isinstance(level, str):
        try:
            level = float(level)
        except ValueError:
            pass
    if not (is_number(level) and 0 <= level <= 100):
        raise FleetError('robot %s: initial_percentage = %r is invalid: must be a number in [0, 100]'
                         % (name, level))
    robot_charging = entry.get('charging', charging)
    if robot_charging not in (True, False, 0, 1):
        raise FleetError('robot %s: charging = %r is invalid: must be true or false' % (name, robot_charging))
    return RobotSpec(name, robot_config, float(level), bool(robot_charging))


def host_share(n, hosts, index):
    """(first robot number, count) of host ``index`` of ``hosts`` that split ``n`` robots evenly
    (fleet.launch's arguments n and hosts); FleetError naming the argument for a bad one."""
    def whole(value):
        if isinstance(value, str):
            try:
                value = int(value.strip())
            except ValueError:
                return None
        return value if isinstance(value, int) and not isinstance(value, bool) else None
    count, host_count = whole(n), whole(hosts)
    if count is None or not 1 <= count <= MAX_ROBOTS:
        raise FleetError('fleet.launch argument n = %r is invalid: must be a whole number of robots in [1, %d]'
                         % (n, MAX_ROBOTS))
    if host_count is None or not 1 <= host_count <= count:
        raise FleetError('fleet.launch argument hosts = %r is invalid: must be a whole number of host processes '
                         'in [1, n = %d]' % (hosts, count))
    first = index * count // host_count
    return first, (index + 1) * count // host_count - first


def robot_params(params, name):
    """A robot's battery parameters in a fleet: its own serial number (the diagnostics' hardware_id), so
    that no two robots of a fleet report the same battery."""
    return replace(params, serial_number='%s-%s' % (params.serial_number, name))


#: a fleet host's own settings beside the battery and publisher ones, with their rules (both front ends)
FLEET_RATE_ALLOWED = 'a number in (0, 100] Hz'
FIRST_ALLOWED = 'a whole number >= 0'
#: the topic of a host's robots' BatteryStates (BatteryFleetState), relative: in the host's namespace on both ROS
#: versions (``/battery_fleet/states`` for a host in ``/``; a host under ``-r __ns:=/site`` publishes
#: ``/site/battery_fleet/states``, as ROS 1's did)
FLEET_STATES = 'battery_fleet/states'


def is_fleet_rate(value):
    """Whether ``value`` is a valid ``fleet_rate`` (battery_fleet/states per second)."""
    return is_number(value) and 0 < value <= 100


def is_first(value):
    """Whether ``value`` is a valid ``first`` (the number of a counted fleet's first robot)."""
    return isinstance(value, int) and not isinstance(value, bool) and value >= 0


#: the host's own settings (``~robots`` is read by robot_specs: a count or a list); Setting as core/node_settings.py
ROBOTS_DESCRIPTION = 'a count N, or the path of a YAML list of {name, config, initial_percentage, charging}'
FLEET_SETTINGS = (
    Setting('prefix', 'robot', lambda v: isinstance(v, str), 'a string', 'with a count: names <prefix><first + k>',
            False),
    Setting('first', 0, lambda v: is_first(v), FIRST_ALLOWED, 'with a count: the first robot number', False),
    Setting('fleet_rate', 1.0, lambda v: is_fleet_rate(v), FLEET_RATE_ALLOWED, FLEET_STATES + ' per second', False),
)


def robot_configs(robots, load, loaded=None):
    """{config path: its BatteryParameters} for every robot's config, each loaded once by ``load(path)``
    (raising ParameterError); FleetError naming the first robot whose config does not load."""
    configs = dict(loaded or {})
    for robot in robots:
        if robot.config not in configs:
            try:
                configs[robot.config] = load(robot.config)
            except ValueError as error:
                raise FleetError('robot %s: config = %r is invalid: %s' % (robot.name, robot.config, error)) \
                    from None
    return configs


def fleet_states(robots):
    """(names, batteries) of a fleet's states message (battery_fleet/states): every robot whose publisher has a
    BatteryState to show (none before its first state, nor under a sensor dropout). ``robots``: (name,
    publisher) pairs, a publisher having ``latest_battery()``."""
    names, batteries = [], []
    for name, publisher in robots:
        battery = publisher.latest_battery()
        if battery is not None:
            names.append(name)
            batteries.append(battery)
    return names, batteries


class Every:
    """Something done every ``period_s``, looked at by a timer every ``tick_s``, first at ``first`` (monotonic s):
    due at a tick up to half a tick before its time, the next one period on; after a stall, on at its own phase (no
    burst to catch up). The ROS 2 fleet host's robots' battery_status, diagnostics and fleet states: robot k's
    status on tick k mod (ticks a period), so every robot's first one goes within one period of the first tick."""

    def __init__(self, first, period_s, tick_s):
        self.next = first
        self._period_s = period_s
        self._slack_s = tick_s / 2.0

    def due(self, now):
        if now + self._slack_s < self.next:
            return False
        behind = now - self._slack_s - self.next
        self.next += self._period_s * (math.floor(behind / self._period_s) + 1 if behind >= 0.0 else 1)
        return True
