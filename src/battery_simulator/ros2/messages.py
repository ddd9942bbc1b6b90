"""A battery's record (core/battery.py) -> sensor_msgs/BatteryState and BatterySimState on ROS 2, and the states
a publisher takes (ros1/messages.py's twin)."""
from sensor_msgs.msg import BatteryState

from battery_simulator.core.battery_record import fill_fields
from battery_simulator.msg import BatterySimState


def battery_state_of(record):
    """The BatteryState of a BatteryRecord, in pack units (V, A, Ah, degC)."""
    return fill_fields(BatteryState(), record.battery_fields())


def sim_state_of(record):
    """The server's full state message: the BatteryState plus what diagnostics and the gate need."""
    return fill_fields(BatterySimState(battery=battery_state_of(record)), record.sim_fields())


class SimState:
    """One update's record as the publisher takes it, its BatterySimState built only when needed (a fleet
    host updates every robot at every tick but publishes each once a period)."""

    def __init__(self, record):
        self._record = record
        self.percentage = record.percentage
        self.power_supply_status = record.power_supply_status
        self.sensor_dropout = record.sensor_dropout
        self._message = None

    def message(self):
        if self._message is None:
            self._message = sim_state_of(self._record)
        return self._message


class ReceivedState:
    """A BatterySimState message from another process's battery, seen as a SimState."""

    def __init__(self, msg):
        self._message = msg
        self.percentage = msg.battery.percentage
        self.power_supply_status = msg.battery.power_supply_status
        self.sensor_dropout = msg.sensor_dropout

    def message(self):
        return self._message
