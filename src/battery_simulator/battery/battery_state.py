"""Model snapshot -> sensor_msgs/BatteryState and BatterySimState (no rospy: message classes only)."""
import math

from sensor_msgs.msg import BatteryState

from battery_simulator.core.battery_model import Health, Status
from battery_simulator.msg import BatterySimState

_SUPPLY_STATUS = {
    Status.CHARGING: BatteryState.POWER_SUPPLY_STATUS_CHARGING,
    Status.DISCHARGING: BatteryState.POWER_SUPPLY_STATUS_DISCHARGING,
    Status.FULL: BatteryState.POWER_SUPPLY_STATUS_FULL,
    Status.EMPTY: BatteryState.POWER_SUPPLY_STATUS_NOT_CHARGING,  # the load is disconnected
    Status.NOT_CHARGING: BatteryState.POWER_SUPPLY_STATUS_NOT_CHARGING,
}
_SUPPLY_HEALTH = {
    Health.GOOD: BatteryState.POWER_SUPPLY_HEALTH_GOOD,
    Health.OVERHEAT: BatteryState.POWER_SUPPLY_HEALTH_OVERHEAT,
    Health.COLD: BatteryState.POWER_SUPPLY_HEALTH_COLD,
}
#: BatterySimState.charging_state (and the diagnostics' "Charging State")
CHARGING_STATE = {
    Status.CHARGING: 'Charging',
    Status.DISCHARGING: 'Discharging',
    Status.FULL: 'Full',
    Status.NOT_CHARGING: 'Not Charging',
    Status.EMPTY: 'Empty',
}


def to_battery_state(snapshot, params, stamp=None, frame_id=''):
    """A BatteryState filled from a model snapshot, in pack units (V, A, Ah, degC)."""
    msg = BatteryState()
    if stamp is not None:
        msg.header.stamp = stamp
    msg.header.frame_id = frame_id
    msg.voltage = snapshot.voltage_v
    msg.temperature = snapshot.temperature_c
    msg.current = snapshot.current_a
    msg.charge = snapshot.charge_ah
    msg.capacity = snapshot.capacity_ah
    msg.design_capacity = snapshot.design_capacity_ah
    msg.percentage = snapshot.percentage / 100.0
    msg.power_supply_status = _SUPPLY_STATUS[snapshot.status]
    msg.power_supply_health = _SUPPLY_HEALTH[snapshot.health]
    msg.power_supply_technology = BatteryState.POWER_SUPPLY_TECHNOLOGY_LION
    msg.present = True
    msg.cell_voltage = [snapshot.cell_voltage_v] * params.cells_series
    msg.cell_temperature = [snapshot.temperature_c] * params.cells_series
    msg.location = params.location
    msg.serial_number = params.serial_number
    return msg


def to_sim_state(snapshot, params, stamp=None, load_power_w=0.0, faults=()):
    """The server's full state message: the BatteryState plus what diagnostics and the gate need."""
    remaining = snapshot.time_remaining_s
    return BatterySimState(
        battery=to_battery_state(snapshot, params, stamp=stamp),
        charging_state=CHARGING_STATE[snapshot.status],
        cut_off=snapshot.cut_off.value if snapshot.cut_off is not None else '',
        cycle_count=snapshot.cycle_count,
        state_of_health=snapshot.state_of_health,
        time_remaining_s=remaining if remaining is not None else math.nan,
        load_power_w=load_power_w,
        active_faults=sorted(faults),
        sensor_dropout='sensor_dropout' in faults,
    )


class SimState:
    """One model update's state, its BatterySimState built only when someone needs it.

    A fleet host updates hundreds of batteries ten times a second but publishes
    each once a second: building every message at every update would be most
    of its work. The cheap fields the publisher reads at every update are
    plain attributes; ``message()`` builds (once) the rest.
    """

    def __init__(self, snapshot, params, stamp, load_power_w=0.0, faults=(), publish_now=False, update=0,
                 add_noise=None):
        self.percentage = snapshot.percentage / 100.0            # as BatteryState.percentage
        self.power_supply_status = _SUPPLY_STATUS[snapshot.status]
        self.sensor_dropout = 'sensor_dropout' in faults
        self.publish_now = publish_now
        self.update = update
        self._parts = (snapshot, params, stamp, load_power_w, faults, add_noise)
        self._message = None

    def message(self):
        """The BatterySimState (built at the first call; noise, if any, drawn then)."""
        if self._message is None:
            snapshot, params, stamp, load_power_w, faults, add_noise = self._parts
            msg = to_sim_state(snapshot, params, stamp=stamp, load_power_w=load_power_w, faults=faults)
            msg.publish_now, msg.update = self.publish_now, self.update
            if add_noise is not None:
                add_noise(msg.battery)
            self._message = msg
        return self._message


class ReceivedState:
    """A BatterySimState received on the server's topic, seen as a SimState."""

    def __init__(self, msg):
        self.percentage = msg.battery.percentage
        self.power_supply_status = msg.battery.power_supply_status
        self.sensor_dropout = msg.sensor_dropout
        self.publish_now = msg.publish_now
        self.update = msg.update
        self._message = msg

    def message(self):
        return self._message
