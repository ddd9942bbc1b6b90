"""What both ROS front ends show, written once (no ROS import).

Fault names, status texts, the supply status and health codes of
sensor_msgs/BatteryState (the same numbers in ROS 1 and ROS 2), the
diagnostics keys and their levels: the rospy nodes, the rclpy nodes, the
fleet hosts and the dashboard all read them from here.
"""
from battery_simulator.core.battery_states import Health, Status

#: the faults inject_fault knows, with what each does
FAULTS = {
    'charger_fault': 'charger connected but no current flows',
    'gauge_stuck': 'the reported percentage freezes while the pack moves on',
    'measurement_noise': 'Gaussian noise on the reported voltage and current',
    'overheat': 'the pack heats past its overheat limit',
    'sensor_dropout': 'battery_status stops; the model runs on',
}


class SupplyStatus:
    """sensor_msgs/BatteryState.power_supply_status values."""
    UNKNOWN = 0
    CHARGING = 1
    DISCHARGING = 2
    NOT_CHARGING = 3
    FULL = 4


class SupplyHealth:
    """sensor_msgs/BatteryState.power_supply_health values."""
    UNKNOWN = 0
    GOOD = 1
    OVERHEAT = 2
    DEAD = 3
    OVERVOLTAGE = 4
    UNSPEC_FAILURE = 5
    COLD = 6
    WATCHDOG_TIMER_EXPIRE = 7
    SAFETY_TIMER_EXPIRE = 8


#: sensor_msgs/BatteryState.power_supply_technology of a Li-ion pack
TECHNOLOGY_LION = 2

SUPPLY_STATUS = {
    Status.CHARGING: SupplyStatus.CHARGING,
    Status.DISCHARGING: SupplyStatus.DISCHARGING,
    Status.FULL: SupplyStatus.FULL,
    Status.EMPTY: SupplyStatus.NOT_CHARGING,   # the load is disconnected
    Status.NOT_CHARGING: SupplyStatus.NOT_CHARGING,
}
SUPPLY_HEALTH = {
    Health.GOOD: SupplyHealth.GOOD,
    Health.OVERHEAT: SupplyHealth.OVERHEAT,
    Health.COLD: SupplyHealth.COLD,
}
#: the two ends of a charge and a discharge: the charging state a goal ends at, and its result text
FULL = 'Full'
EMPTY = 'Empty'
#: BatterySimState.charging_state and the diagnostics' "Charging State", by model status
CHARGING_STATE = {
    Status.CHARGING: 'Charging',
    Status.DISCHARGING: 'Discharging',
    Status.FULL: FULL,
    Status.NOT_CHARGING: 'Not Charging',
    Status.EMPTY: EMPTY,
}
CHARGING_STATES = tuple(CHARGING_STATE.values())
#: the diagnostics' "Health", by power_supply_health
HEALTH_TEXT = {
    SupplyHealth.GOOD: 'Good',
    SupplyHealth.OVERHEAT: 'Overheat',
    SupplyHealth.COLD: 'Cold',
    SupplyHealth.DEAD: 'Dead',
    SupplyHealth.OVERVOLTAGE: 'Overvoltage',
    SupplyHealth.UNSPEC_FAILURE: 'Failure',
    SupplyHealth.WATCHDOG_TIMER_EXPIRE: 'Watchdog timer expired',
    SupplyHealth.SAFETY_TIMER_EXPIRE: 'Safety timer expired',
    SupplyHealth.UNKNOWN: 'Unknown',
}
#: the dashboard's status text, by power_supply_status (a driver that is not this simulator)
SUPPLY_STATUS_TEXT = {SupplyStatus.CHARGING: 'Charging', SupplyStatus.DISCHARGING: 'Discharging',
                      SupplyStatus.NOT_CHARGING: 'Not charging', SupplyStatus.FULL: 'Full'}


class DiagnosticLevel:
    """diagnostic_msgs/DiagnosticStatus levels."""
    OK = 0
    WARN = 1
    ERROR = 2
    STALE = 3


#: the diagnostics status name after the node's resolved name
DIAGNOSTIC_SUFFIX = ': Battery'
#: the keys of the "Battery" diagnostic status, in order (interface Part 2, Part 5's cell keys, Part 9's gauge keys)
DIAGNOSTIC_KEYS = ('Voltage (V)', 'Current (A)', 'Charge (Ah)', 'Capacity (Ah)', 'Design Capacity (Ah)',
                   'Percentage (%)', 'Temperature (C)', 'Charging State', 'Health', 'Cycle Count',
                   'State of Health (%)', 'Time Remaining (min)', 'Cell Voltage Min (V)', 'Cell Voltage Max (V)',
                   'Cell Imbalance (mV)', 'Gauge Corrections', 'Gauge Full Capacity (Ah)', 'Gauge Learned')
