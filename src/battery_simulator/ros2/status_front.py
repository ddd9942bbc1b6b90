"""battery_state_pub's role for one battery on ROS 2: ``battery_status``, ``battery_low`` /
``battery_critical`` and its "Battery" diagnostic status, from the battery's records.

It runs no model: ``on_state(state, publish_now)`` takes each update's state (a
core BatteryRecord from an in-process battery, or a BatterySimState message
received from another process); ``publish_once()`` is called at ``rate`` Hz; a
change of power_supply_status or a service's change goes out at once.
"""

from diagnostic_msgs.msg import DiagnosticStatus, KeyValue
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import BatteryState
from std_msgs.msg import Bool

from battery_simulator.core import diagnostics
from battery_simulator.core.battery import fill_fields
from battery_simulator.core.latest_state import LatestState
from battery_simulator.core.level_alarm import LevelAlarm
from battery_simulator.core.names import DIAGNOSTIC_SUFFIX
from battery_simulator.ros import topics

#: battery_status: reliable, volatile, depth 10 (what Nav2's battery conditions and docking subscribe with)
STATUS_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=10, reliability=ReliabilityPolicy.RELIABLE,
                        durability=DurabilityPolicy.VOLATILE)
#: battery_low / battery_critical: reliable, transient local (ROS 2's latched)
LATCHED_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1, reliability=ReliabilityPolicy.RELIABLE,
                         durability=DurabilityPolicy.TRANSIENT_LOCAL)


class ReceivedState:
    """A BatterySimState message from another process's battery, seen as a record."""

    def __init__(self, msg):
        self.message = msg
        self.percentage = msg.battery.percentage
        self.power_supply_status = msg.battery.power_supply_status
        self.sensor_dropout = msg.sensor_dropout


class RecordState:
    """An in-process battery's BatteryRecord; its messages are built at the first need."""

    def __init__(self, record, sim_state_class):
        self._record, self._class = record, sim_state_class
        self.percentage = record.percentage
        self.power_supply_status = record.power_supply_status
        self.sensor_dropout = record.sensor_dropout
        self._message = None

    @property
    def message(self):
        if self._message is None:
            self._message = sim_state_message(self._class, self._record)
        return self._message


def battery_message(record):
    return fill_fields(BatteryState(), record.battery_fields())


def sim_state_message(sim_state_class, record):
    """A ROS 2 BatterySimState of a core BatteryRecord."""
    return fill_fields(sim_state_class(battery=battery_message(record)), record.sim_fields())


class StatusFront:
    """battery_state_pub's publishers for one battery whose names live under ``namespace`` of ``node``."""

    def __init__(self, node, namespace, diagnostic_name, rate, frame_id, stale_timeout, low_percentage,
                 critical_percentage, hysteresis, log):
        self.rate = rate
        self._node = node
        self._frame_id = frame_id
        self._diagnostic_name = diagnostic_name + DIAGNOSTIC_SUFFIX
        self._log = log
        self._state = LatestState(stale_timeout, log, 'the battery', 'the battery')
        self._published_status = None
        self._alarms = {'low': LevelAlarm(low_percentage, hysteresis),
                        'critical': LevelAlarm(critical_percentage, hysteresis)}
        self._pub = node.create_publisher(BatteryState, namespace + topics.BATTERY_STATUS, STATUS_QOS)
        self._alarm_pubs = {
            'low': node.create_publisher(Bool, namespace + topics.BATTERY_LOW, LATCHED_QOS),
            'critical': node.create_publisher(Bool, namespace + topics.BATTERY_CRITICAL, LATCHED_QOS)}
        for publisher in self._alarm_pubs.values():
            publisher.publish(Bool(data=False))

    def on_state(self, state, publish_now=False):
        """The battery's state after an update; a service's change (``publish_now``) or a status change
        goes out at once."""
        self._state.take(state)
        for name, alarm in self._alarms.items():
            if alarm.update(state.percentage):
                self._log.info('battery %s: %s at %.1f %%', name, alarm.active, 100.0 * state.percentage)
                self._alarm_pubs[name].publish(Bool(data=alarm.active))
        changed = self._published_status is not None and state.power_supply_status != self._published_status
        if publish_now or changed:
            self.publish_once()

    def latest_battery(self):
        """The latest BatteryState (None before the first, or while a sensor dropout holds it back)."""
        latest = self._state.latest
        return None if latest is None or latest.sensor_dropout else latest.message.battery

    def publish_once(self):
        """Publish the latest state, freshly stamped (or nothing: no state yet, or a sensor dropout)."""
        latest = self._state.to_publish()
        if latest is None:
            self._published_status = None
            return
        msg = latest.message.battery
        msg.header.stamp = self._node.get_clock().now().to_msg()
        msg.header.frame_id = self._frame_id
        self._published_status = msg.power_supply_status
        self._pub.publish(msg)

    def diagnostic_status(self):
        """The "<node>: Battery" status (core/diagnostics.py's keys and levels)."""
        status = DiagnosticStatus(name=self._diagnostic_name)
        latest = self._state.latest
        if latest is None:
            level, status.message = diagnostics.no_data_yet()
            status.level, status.hardware_id = bytes([level]), 'none'
            return status
        stale = self._state.stale()
        msg = latest.message
        status.hardware_id = msg.battery.serial_number or 'none'
        level, status.message = diagnostics.battery_level(msg, stale, self._alarms['low'].threshold,
                                                          self._alarms['critical'].threshold)
        status.level = bytes([level])
        status.values = [KeyValue(key=key, value=value) for key, value in diagnostics.battery_values(msg)]
        return status
