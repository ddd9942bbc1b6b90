"""battery_state_pub's rules for one battery, for both front ends (no ROS import).

What a state publisher decides, written once: the latest state and when it is
stale (core/latest_state.py), the two alarms with hysteresis (battery_low and
battery_critical), when a state goes out at once rather than at the next tick
(a service's change, a power_supply_status change), and the "Battery"
diagnostic status's level, summary and values (core/diagnostics.py). The front
ends (ros1/state_publisher.py, ros2/state_publisher.py) keep only their
publishers, stamps and locks.

A state is anything with ``percentage``, ``power_supply_status``,
``sensor_dropout`` and ``message()`` (the BatterySimState message, built at the
first need: a fleet host's states are mostly never published).
"""
import copy
from collections import namedtuple

from battery_simulator.core import diagnostics
from battery_simulator.core.battery_record import apply_conventions
from battery_simulator.core.latest_state import LatestState
from battery_simulator.core.level_alarm import LevelAlarm

ALARMS = ('low', 'critical')
#: a burst of send-now changes (a flood of services or contact changes) goes out as at most one battery_status per
#: battery per this, carrying its last state (ROS 1's ChangeLoop thread; ROS 2's BatteryStatePublisher, a one-shot
#: timer)
URGENT_GAP_S = 0.02

#: what taking a state asks of the front end: the alarms whose value changed ((name, active), ...) and
#: whether to publish now (a service's change, or a change of power_supply_status)
Reaction = namedtuple('Reaction', 'alarm_changes publish_now')
#: the diagnostic status: level (0 OK, 1 WARN, 2 ERROR), summary, hardware_id, [(key, value), ...]
DiagnosticReport = namedtuple('DiagnosticReport', 'level message hardware_id values')


class StatusRules:
    """The latest state, the low/critical alarms, "send now" and the diagnostics of one battery."""

    def __init__(self, stale_timeout, low_percentage, critical_percentage, hysteresis, log, waiting_for, source):
        self.latest_state = LatestState(stale_timeout, log, waiting_for, source)
        self.alarms = {'low': LevelAlarm(low_percentage, hysteresis),
                       'critical': LevelAlarm(critical_percentage, hysteresis)}
        self._log = log
        self._published_status = None

    def take(self, state, publish_now=False):
        """The battery's state after an update -> Reaction (the alarm changes, said in the log, and whether
        the state goes out at once)."""
        self.latest_state.take(state)
        changes = []
        for name in ALARMS:
            alarm = self.alarms[name]
            if alarm.update(state.percentage):
                self._log.info('battery %s: %s at %.1f %%', name, alarm.active, 100.0 * state.percentage)
                changes.append((name, alarm.active))
        status_changed = (self._published_status is not None
                          and state.power_supply_status != self._published_status)
        return Reaction(changes, publish_now or status_changed)

    def to_publish(self):
        """The BatteryState message to publish now (to be stamped), or None: no state yet, or a sensor
        dropout (said in the log, throttled); the stale rule's lines too. In the config's ``conventions``
        (a driver emulated: the current's sign inverted, percentage 0-100), on a copy: the alarms and the
        diagnostics keep reading the package's conventions."""
        latest = self.latest_state.to_publish()
        if latest is None:
            self._published_status = None
            return None
        state = latest.message()
        battery = state.battery
        self._published_status = battery.power_supply_status
        conventions = conventions_of(state)
        if conventions:
            battery = copy.deepcopy(battery)
            battery.current, battery.percentage = apply_conventions(battery.current, battery.percentage,
                                                                    conventions)
        return battery

    def latest_battery(self):
        """The latest BatteryState message (None before the first, or while a sensor dropout holds it back):
        what a fleet's states message carries."""
        latest = self.latest_state.latest
        return None if latest is None or latest.sensor_dropout else latest.message().battery

    def diagnostic(self):
        """The "Battery" diagnostic status (core/diagnostics.py's keys and levels) as a DiagnosticReport."""
        latest = self.latest_state.latest
        if latest is None:
            level, message = diagnostics.no_data_yet()
            return DiagnosticReport(level, message, 'none', [])
        msg = latest.message()
        level, message = diagnostics.battery_level(msg, self.latest_state.stale(), self.alarms['low'].threshold,
                                                   self.alarms['critical'].threshold)
        return DiagnosticReport(level, message, msg.battery.serial_number or 'none',
                                list(diagnostics.battery_values(msg)))


def conventions_of(state):
    """The conventions a BatterySimState carries ({} for the package's own: sign as REP 147, percentage 0-1)."""
    conventions = {}
    if getattr(state, 'invert_current_sign', False):
        conventions['invert_current_sign'] = True
    scale = getattr(state, 'percentage_scale', 0.0)
    if scale and scale != 1.0:
        conventions['percentage_scale'] = scale
    return conventions
