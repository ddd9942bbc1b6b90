"""The "<node>: Battery" diagnostic status's rules, ROS-free: its level, summary and key/value pairs.

Both front ends read a battery_simulator/BatterySimState message (rospy's or
rclpy's: the same field names) and wrap what these functions return in their
own diagnostic_msgs classes.
"""
import math

from battery_simulator.core.status_codes import EMPTY, HEALTH_TEXT, DiagnosticLevel, SupplyHealth

#: the "Battery" diagnostic status goes out at least this often (wall time: a paused sim clock does not stop it)
DIAGNOSTIC_PERIOD_S = 0.5


def battery_level(state, stale, low, critical):
    """(level, summary) for a BatterySimState: ERROR critical or empty, WARN low, unhealthy, stale or imbalanced."""
    battery = state.battery
    if state.charging_state == EMPTY:
        return DiagnosticLevel.ERROR, '%s: %s' % (EMPTY, state.cut_off or 'load cut off')
    if battery.percentage < critical:
        return DiagnosticLevel.ERROR, 'Critical: %.1f %%' % (100.0 * battery.percentage)
    if stale:
        return DiagnosticLevel.WARN, 'Stale: no update from the battery_simulator server'
    if battery.power_supply_health != SupplyHealth.GOOD:
        return DiagnosticLevel.WARN, 'Health: %s' % HEALTH_TEXT.get(battery.power_supply_health, 'Unknown')
    if battery.percentage < low:
        return DiagnosticLevel.WARN, 'Low: %.1f %%' % (100.0 * battery.percentage)
    imbalance_v = cell_imbalance_v(battery)
    if imbalance_v > getattr(state, 'imbalance_warn_v', math.inf):
        return DiagnosticLevel.WARN, 'Imbalance: %.0f mV between the cells (above %.0f mV)' % (
            1000.0 * imbalance_v, 1000.0 * state.imbalance_warn_v)
    return DiagnosticLevel.OK, '%s, %.1f %%' % (state.charging_state, 100.0 * battery.percentage)


def battery_values(state):
    """The status's (key, value) pairs, in the interface's order (names.DIAGNOSTIC_KEYS)."""
    battery = state.battery
    remaining = state.time_remaining_s
    cells = list(battery.cell_voltage)
    return [
        ('Voltage (V)', '%.3f' % battery.voltage),
        ('Current (A)', '%.3f' % battery.current),
        ('Charge (Ah)', '%.3f' % battery.charge),
        ('Capacity (Ah)', '%.3f' % battery.capacity),
        ('Design Capacity (Ah)', '%.3f' % battery.design_capacity),
        ('Percentage (%)', '%.1f' % (100.0 * battery.percentage)),
        ('Temperature (C)', '%.1f' % battery.temperature),
        ('Charging State', state.charging_state),
        ('Health', HEALTH_TEXT.get(battery.power_supply_health, 'Unknown')),
        ('Cycle Count', '%.2f' % state.cycle_count),
        ('State of Health (%)', '%.1f' % (100.0 * state.state_of_health)),
        ('Time Remaining (min)', '' if math.isnan(remaining) else '%.1f' % (remaining / 60.0)),
        ('Cell Voltage Min (V)', '%.3f' % min(cells) if cells else ''),
        ('Cell Voltage Max (V)', '%.3f' % max(cells) if cells else ''),
        ('Cell Imbalance (mV)', '%.1f' % (1000.0 * cell_imbalance_v(battery))),
        ('Gauge Corrections', '%d' % getattr(state, 'gauge_corrections', 0)),
        ('Gauge Full Capacity (Ah)', '%.3f' % getattr(state, 'gauge_full_capacity_ah', battery.capacity)),
        ('Gauge Learned', 'true' if getattr(state, 'gauge_learned', False) else 'false'),
    ]


def cell_imbalance_v(battery):
    """The spread of the cell (group) voltages, V (0 with fewer than two)."""
    cells = list(battery.cell_voltage)
    return max(cells) - min(cells) if len(cells) > 1 else 0.0


def no_data_yet():
    """(level, summary) before the first state."""
    return DiagnosticLevel.WARN, 'no data from the battery_simulator server yet'
