"""A battery's record (core/battery.py) -> sensor_msgs/BatteryState and BatterySimState (no rospy:
message classes only)."""
from sensor_msgs.msg import BatteryState

from battery_simulator.core.battery_record import BatteryRecord, fill_fields as fill
from battery_simulator.msg import BatterySimState

#: Updates queued for each battery_simulator/state subscriber, on both ends (1 s at 100 Hz): none is dropped. A
#: queue of 1 dropped an update whose writer thread was not scheduled before the next (10 ms at 100 Hz; 4 of 20
#: runs on a busy machine), and with it a service's publish_now: battery_state_pub never acknowledged it and the
#: service replied after its full wait (SERVICE_PUBLISH_WAIT_S), its change not sent at once.
STATE_QUEUE_SIZE = 100


def battery_state_of(record, stamp=None, frame_id=''):
    """The BatteryState of a BatteryRecord, in pack units (V, A, Ah, degC)."""
    msg = fill(BatteryState(), record.battery_fields())
    if stamp is not None:
        msg.header.stamp = stamp
    msg.header.frame_id = frame_id
    return msg


def sim_state_of(record, stamp=None):
    """The server's full state message: the BatteryState plus what diagnostics and the gate need."""
    return fill(BatterySimState(battery=battery_state_of(record, stamp=stamp)), record.sim_fields())


def to_battery_state(snapshot, params, stamp=None, frame_id=''):
    """A BatteryState filled from a model snapshot."""
    return battery_state_of(BatteryRecord(snapshot, params), stamp, frame_id)


def to_sim_state(snapshot, params, stamp=None, load_power_w=0.0, faults=()):
    """A BatterySimState filled from a model snapshot."""
    return sim_state_of(BatteryRecord(snapshot, params, load_power_w, faults), stamp)


class SimState:
    """One model update's record as the publisher takes it, its BatterySimState built only when needed.

    A fleet host updates hundreds of batteries ten times a second but publishes
    each once a second: building every message at every update would be most
    of its work. The cheap fields the publisher reads at every update are
    plain attributes; ``message()`` builds (once) the rest.
    """

    def __init__(self, record, stamp, publish_now=False, update=0):
        self.percentage = record.percentage
        self.power_supply_status = record.power_supply_status
        self.sensor_dropout = record.sensor_dropout
        self.publish_now = publish_now
        self.update = update
        self._record, self._stamp = record, stamp
        self._message = None

    def message(self):
        """The BatterySimState (built at the first call; noise, if any, drawn then)."""
        if self._message is None:
            msg = sim_state_of(self._record, stamp=self._stamp)
            msg.publish_now, msg.update = self.publish_now, self.update
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

