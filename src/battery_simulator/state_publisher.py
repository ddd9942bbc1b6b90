"""The BatteryState publisher node (battery_state_pub).

It runs no model: it republishes the server's latest state on
``battery_status`` at ``~rate`` Hz, stamped with the current ROS time, so the
topic and the action feedback always describe the same battery. When the
server goes quiet it keeps publishing the last state with a stale-data
warning, and resumes when the server is back.

:ROS Parameters:
  - ``~rate`` (float, Hz, 0 < r <= 1000): publication rate (default 1.0)
  - ``~frame_id`` (str): header.frame_id (default "battery")
  - ``~stale_timeout`` (float, s > 0): warn after this long without an update (default 3.0)

:Subscribes:
  - ``battery_simulator/battery_state`` (sensor_msgs/BatteryState): from battery_sim_server.py
:Publishes:
  - ``battery_status`` (sensor_msgs/BatteryState)
"""
import copy
import threading
import time

import rospy
from sensor_msgs.msg import BatteryState

from battery_simulator.action_server import STATE_TOPIC
from battery_simulator.ros_parameters import (StartupError, checked_param, exit_on_startup_error,
                                              is_number)


def read_settings():
    """All start-up parameters, checked; raises StartupError."""
    return dict(
        rate=checked_param('~rate', 1.0, lambda v: is_number(v) and 0 < v <= 1000, 'a number in (0, 1000] Hz'),
        frame_id=checked_param('~frame_id', 'battery', lambda v: isinstance(v, str), 'a string'),
        stale_timeout=checked_param('~stale_timeout', 3.0, lambda v: is_number(v) and v > 0, 'a number > 0 s'),
    )


class BatteryStatePublisher:
    def __init__(self, rate, frame_id, stale_timeout):
        self._rate_hz = rate
        self._frame_id = frame_id
        self._stale_timeout_s = stale_timeout
        self._lock = threading.Lock()   # guards _latest and _received_at
        self._latest = None
        self._received_at = 0.0
        self._stale = False
        self._pub = rospy.Publisher('battery_status', BatteryState, queue_size=10)
        self._sub = rospy.Subscriber(STATE_TOPIC, BatteryState, self._on_state, queue_size=1)

    def _on_state(self, msg):
        with self._lock:
            self._latest, self._received_at = msg, time.monotonic()

    def spin(self):
        rate = rospy.Rate(self._rate_hz)
        while not rospy.is_shutdown():
            self.publish_once()
            try:
                rate.sleep()
            except rospy.ROSInterruptException:
                break

    def publish_once(self):
        with self._lock:
            latest, received_at = self._latest, self._received_at
        if latest is None:
            rospy.loginfo_throttle(10.0, 'waiting for %s', rospy.resolve_name(STATE_TOPIC))
            return
        stale = time.monotonic() - received_at > self._stale_timeout_s
        if stale:
            rospy.logwarn_throttle(10.0, 'battery state is stale: no update from the battery_simulator '
                                   'server for %.0f s; republishing the last known state',
                                   time.monotonic() - received_at)
        elif self._stale:
            rospy.loginfo('battery state updates resumed')
        self._stale = stale
        msg = copy.copy(latest)
        msg.header = copy.copy(latest.header)
        msg.header.stamp = rospy.Time.now()
        msg.header.frame_id = self._frame_id
        self._pub.publish(msg)


def main():
    rospy.init_node('battery_state_pub')
    try:
        settings = read_settings()
    except StartupError as error:
        exit_on_startup_error(error)
    BatteryStatePublisher(**settings).spin()
