"""battery_state_pub's role for one battery on ROS 1 (ros2/state_publisher.py's twin; its main:
battery_state_pub.py).

It runs no model: it republishes the server's latest state on
``battery_status`` at ``~rate`` Hz, stamped with the current ROS time, so the
topic and the action feedback always describe the same battery. A change of
power_supply_status, or one a server service made (set_state, reset, a fault,
a load), is published at once, whatever the rate. It also turns
the level into ``battery_low`` / ``battery_critical`` events (with hysteresis)
and publishes REP-107 diagnostics. When the server goes quiet it keeps
publishing the last state with a stale-data warning, and resumes when the
server is back.

:ROS Parameters:
  - ``~rate`` (float, Hz, 0 < r <= 1000): publication rate (default 1.0)
  - ``~frame_id`` (str): header.frame_id (default "battery")
  - ``~stale_timeout`` (float, s > 0): warn after this long without an update (default 3.0)
  - ``~low_percentage`` (float, 0..1): battery_low below this (default 0.20)
  - ``~critical_percentage`` (float, 0..1, <= low): battery_critical below this (default 0.05)
  - ``~hysteresis`` (float, 0..1): an event clears above its threshold plus this (default 0.05)
  - ``~battery_state_topic`` (str): the same BatteryState also on this topic, relative to the robot
    (default battery_state, what opennav_docking reads; empty: battery_status only)

:Subscribes:
  - ``battery_simulator/state`` (battery_simulator/BatterySimState): from the server (ros1/action_server.py)
:Publishes:
  - ``battery_status`` (sensor_msgs/BatteryState), and the same on ``battery_state`` (``~battery_state_topic``)
  - ``battery_low``, ``battery_critical`` (std_msgs/Bool, latched)
  - ``battery_simulator/status_sent`` (std_msgs/UInt64): a service's change is out (the server then replies)
  - ``/diagnostics`` (diagnostic_msgs/DiagnosticArray): status "<node>: Battery"
"""
import threading

import rospy
from diagnostic_updater import DiagnosticStatusWrapper
from sensor_msgs.msg import BatteryState
from std_msgs.msg import Bool, UInt64

from battery_simulator.core import ros_names
from battery_simulator.core.status_codes import DIAGNOSTIC_SUFFIX
from battery_simulator.core.status_rules import StatusRules
from battery_simulator.msg import BatterySimState
from battery_simulator.ros1.log import RobotLog
from battery_simulator.ros1.messages import STATE_QUEUE_SIZE, ReceivedState


class BatteryStatePublisher:
    """battery_state_pub's logic for one battery whose names live under ``namespace``.

    It holds no thread: ``publish_once()`` is called at ``rate`` by the process's
    publish loop, changes go out through the shared ChangeLoop, diagnostics
    through the shared DiagnosticsLoop. ``on_state`` takes the server's state,
    from the server's topic (battery_state_pub.py) or straight from the server
    (a fleet host); ``acknowledge(update)`` tells the server a service's change
    is out, on its topic or straight. The rules are core/status_rules.py's; ``self._lock`` guards them.
    """

    def __init__(self, namespace, node_name, rate, frame_id, stale_timeout, low_percentage, critical_percentage,
                 hysteresis, changes, battery_state_topic='', log=None):
        self.rate = rate
        self._frame_id = frame_id
        self._diagnostic_name = node_name.lstrip('/') + DIAGNOSTIC_SUFFIX
        self._changes = changes
        self._log = log or RobotLog()
        self._lock = threading.Lock()
        self._rules = StatusRules(stale_timeout, low_percentage, critical_percentage, hysteresis, self._log,
                                  namespace + ros_names.STATE_TOPIC, 'the battery_simulator server')
        self._pubs = [rospy.Publisher(namespace + ros_names.BATTERY_STATUS, BatteryState, queue_size=10)]
        if battery_state_topic:   # the same message for the readers of battery_state (opennav_docking)
            self._pubs.append(rospy.Publisher(ros_names.robot_topic(namespace, battery_state_topic), BatteryState,
                                              queue_size=10))
        self._alarm_pubs = {name: rospy.Publisher(namespace + topic, Bool, queue_size=1, latch=True)
                            for name, topic in (('low', ros_names.BATTERY_LOW), ('critical', ros_names.BATTERY_CRITICAL))}
        for publisher in self._alarm_pubs.values():
            publisher.publish(Bool(data=False))
        self.acknowledge = self._acknowledge_on_topic
        self._sent_pub = None
        self._namespace = namespace

    def follow_topic(self):
        """Take the server's state from its topic (a server in another process) and acknowledge on a topic."""
        self._sent_pub = rospy.Publisher(self._namespace + ros_names.STATUS_SENT, UInt64, queue_size=10)
        self._sub = rospy.Subscriber(self._namespace + ros_names.STATE_TOPIC, BatterySimState,
                                     lambda msg: self.on_state(ReceivedState(msg)), queue_size=STATE_QUEUE_SIZE)

    def _acknowledge_on_topic(self, update):
        self._sent_pub.publish(UInt64(data=update))

    def latest_battery(self):
        """The latest BatteryState (None before the first), for a fleet's summary."""
        with self._lock:
            return self._rules.latest_battery()

    def on_state(self, state):
        """The server's state after an update (a SimState, or a ReceivedState from its topic)."""
        with self._lock:
            reaction = self._rules.take(state, state.publish_now)
        for name, active in reaction.alarm_changes:
            self._alarm_pubs[name].publish(Bool(data=active))
        if reaction.publish_now:
            # a service's change or a status change goes out at once, not at the next tick
            self._changes.request(self, state.update if state.publish_now else 0)

    def publish_once(self):
        """Publish the latest state, freshly stamped (or nothing: no state yet, or a sensor dropout)."""
        with self._lock:
            # The server's message is ours alone (a fresh one per update) and publish() serializes it
            # before returning, so it is restamped in place rather than copied on every tick.
            msg = self._rules.to_publish()
            if msg is None:
                return
            msg.header.stamp = rospy.Time.now()
            msg.header.frame_id = self._frame_id
            for publisher in self._pubs:
                publisher.publish(msg)   # rospy serializes nothing for a topic without subscribers

    def diagnostic_status(self):
        """The "<node>: Battery" diagnostic status (keys as rqt_robot_monitor and dashboards expect)."""
        with self._lock:
            report = self._rules.diagnostic()
        status = DiagnosticStatusWrapper(name=self._diagnostic_name)
        status.summary(report.level, report.message)
        status.hardware_id = report.hardware_id
        for key, value in report.values:
            status.add(key, value)
        return status


def repeat_at_rate(rate_hz, action):
    """``action()`` at ``rate_hz`` (ROS time) until shutdown, in the calling thread."""
    rate = rospy.Rate(rate_hz, reset=True)   # reset: a /clock jump back restarts the rate
    while not rospy.is_shutdown():
        action()
        try:
            rate.sleep()
        except rospy.ROSInterruptException:
            break


def publish_at_rate(publishers, rate_hz):
    """Publish every publisher's battery_status at ``rate_hz`` (ROS time) until shutdown (the main thread)."""
    def publish_all():
        for publisher in publishers:
            publisher.publish_once()
    repeat_at_rate(rate_hz, publish_all)

