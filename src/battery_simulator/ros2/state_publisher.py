"""battery_state_pub's role for one battery on ROS 2: ``battery_status``, ``battery_low`` /
``battery_critical`` and its "Battery" diagnostic status (ros1/state_publisher.py's twin).

It runs no model: ``on_state(state, publish_now)`` takes each update's state (a
SimState of an in-process battery, or a ReceivedState of a BatterySimState from
another process); ``publish_once()`` is called at ``rate`` Hz. The rules (stale,
alarms, send now, diagnostics) are core/status_rules.py's.

A burst of send-now changes (a flapping contact, a storm of services) goes out
as at most one message every URGENT_GAP_S, carrying its last state, as ROS 1's
ChangeLoop sends it: the first at once, the rest held by a one-shot timer.
"""
import time

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from sensor_msgs.msg import BatteryState
from std_msgs.msg import Bool

from battery_simulator.core import ros_names
from battery_simulator.core.diagnostics import DIAGNOSTIC_PERIOD_S
from battery_simulator.core.status_codes import DIAGNOSTIC_SUFFIX
from battery_simulator.core.status_rules import URGENT_GAP_S, StatusRules
from battery_simulator.msg import BatterySimState
from battery_simulator.ros2.messages import ReceivedState
from battery_simulator.ros2.qos import LATCHED_QOS, STATUS_QOS
from battery_simulator.ros2.startup import steady_clock


class BatteryStatePublisher:
    """battery_state_pub's publishers for one battery whose names live under ``namespace`` of ``node``."""

    def __init__(self, node, namespace, diagnostic_name, rate, frame_id, stale_timeout, low_percentage,
                 critical_percentage, hysteresis, log, battery_state_topic=''):
        self.rate = rate
        self._node = node
        self._frame_id = frame_id
        self._diagnostic_name = diagnostic_name + DIAGNOSTIC_SUFFIX
        self._rules = StatusRules(stale_timeout, low_percentage, critical_percentage, hysteresis, log,
                                  'the battery', 'the battery')
        self._pub = node.create_publisher(BatteryState, namespace + ros_names.BATTERY_STATUS, STATUS_QOS)
        # the same message for the readers of battery_state (opennav_docking), sent while one listens
        self._twin = node.create_publisher(BatteryState, ros_names.robot_topic(namespace, battery_state_topic),
                                           STATUS_QOS) if battery_state_topic else None
        self._alarm_pubs = {name: node.create_publisher(Bool, namespace + topic, LATCHED_QOS)
                            for name, topic in (('low', ros_names.BATTERY_LOW), ('critical', ros_names.BATTERY_CRITICAL))}
        for publisher in self._alarm_pubs.values():
            publisher.publish(Bool(data=False))
        self._sent_now_at = -URGENT_GAP_S   # monotonic time of the last send-now message
        self._held = None                   # the one-shot timer of a held send-now, while one waits

    def on_state(self, state, publish_now=False):
        """The battery's state after an update; a service's change (``publish_now``) or a status change
        goes out at once (a burst: one message every URGENT_GAP_S, the last state)."""
        reaction = self._rules.take(state, publish_now)
        for name, active in reaction.alarm_changes:
            self._alarm_pubs[name].publish(Bool(data=active))
        if reaction.publish_now:
            self._send_now()

    def _send_now(self):
        if self._held is not None:   # one is held: it goes out with the latest state (a late timer included)
            return
        wait_s = self._sent_now_at + URGENT_GAP_S - time.monotonic()
        if wait_s <= 0.0:
            self._sent_now_at = time.monotonic()
            self.publish_once()
        else:
            self._held = self._node.create_timer(wait_s, self._send_held, clock=steady_clock())

    def _send_held(self):
        self._node.destroy_timer(self._held)   # one shot: a fleet host's thousand robots keep no idle timers
        self._held = None
        self._sent_now_at = time.monotonic()
        self.publish_once()

    def latest_battery(self):
        """The latest BatteryState (None before the first, or while a sensor dropout holds it back)."""
        return self._rules.latest_battery()

    def publish_once(self):
        """Publish the latest state, freshly stamped (or nothing: no state yet, or a sensor dropout)."""
        msg = self._rules.to_publish()
        if msg is None:
            return
        msg.header.stamp = self._node.get_clock().now().to_msg()
        msg.header.frame_id = self._frame_id
        self._pub.publish(msg)
        if self._twin is not None and self._twin.get_subscription_count() > 0:
            self._twin.publish(msg)

    def diagnostic_status(self):
        """The "<node>: Battery" status."""
        report = self._rules.diagnostic()
        return DiagnosticStatus(name=self._diagnostic_name, level=bytes([report.level]), message=report.message,
                                hardware_id=report.hardware_id,
                                values=[KeyValue(key=key, value=value) for key, value in report.values])


def diagnostics_publisher(node, status_fronts):
    """publish(): every status front's "Battery" status in one DiagnosticArray on /diagnostics."""
    publisher = node.create_publisher(DiagnosticArray, ros_names.DIAGNOSTICS, 10)

    def publish():
        array = DiagnosticArray(status=[front.diagnostic_status() for front in status_fronts])
        array.header.stamp = node.get_clock().now().to_msg()
        publisher.publish(array)
    return publish


def publish_diagnostics(node, status_fronts):
    """The diagnostics every DIAGNOSTIC_PERIOD_S, on a timer of their own (one battery)."""
    return node.create_timer(DIAGNOSTIC_PERIOD_S, diagnostics_publisher(node, status_fronts), clock=steady_clock())


def follow_battery(node, settings, log):
    """A BatteryStatePublisher on ``node`` following the state topic of the battery of its namespace (a
    battery_simulator node in another process: ROS 1's battery_state_pub), with its timers."""
    status = BatteryStatePublisher(node, '', node.get_fully_qualified_name().lstrip('/'), log=log, **settings)
    node.create_subscription(BatterySimState, ros_names.STATE_TOPIC,
                             lambda msg: status.on_state(ReceivedState(msg), msg.publish_now), STATUS_QOS)
    node.create_timer(1.0 / settings['rate'], status.publish_once, clock=steady_clock())
    publish_diagnostics(node, [status])
    log.info('battery_state_pub: following %s', node.resolve_topic_name(ros_names.STATE_TOPIC))
    return status
