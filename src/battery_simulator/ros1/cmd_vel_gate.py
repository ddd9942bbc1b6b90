"""The cut-off gate (battery_cmd_vel_gate): no battery, no motion.

Relays ``cmd_vel_in`` to ``cmd_vel_out`` while the battery can supply the
motors. When the server reports the pack Empty (its protection has cut the
load off) it publishes one zero Twist and drops every command until the
battery is no longer empty, as a real robot stops when its battery dies.
A command with a NaN or infinite value is never relayed: a zero Twist goes
out instead (once, until a finite command comes), with a log line.

:Subscribes:
  - ``cmd_vel_in`` (geometry_msgs/Twist): the controller's commands
  - ``battery_simulator/state`` (battery_simulator/BatterySimState): from battery_sim_server.py
:Publishes:
  - ``cmd_vel_out`` (geometry_msgs/Twist)
"""
import math
import threading

import rospy
from geometry_msgs.msg import Twist

from battery_simulator.msg import BatterySimState
from battery_simulator.core import topics


class CmdVelGate:
    def __init__(self):
        self._lock = threading.Lock()   # guards _empty, _bad_command and the stops published
        self._empty = False
        self._bad_command = False       # the last command was non-finite (a zero Twist was sent for it)
        self._pub = rospy.Publisher('cmd_vel_out', Twist, queue_size=10)
        self._state_sub = rospy.Subscriber(topics.STATE_TOPIC, BatterySimState, self._on_state, queue_size=10)
        self._cmd_sub = rospy.Subscriber('cmd_vel_in', Twist, self._on_cmd_vel, queue_size=10)

    def _on_state(self, state):
        empty = state.charging_state == 'Empty'
        with self._lock:
            changed, self._empty = empty != self._empty, empty
            if changed and empty:
                self._pub.publish(Twist())   # the motors stop
        if changed:
            if empty:
                rospy.logwarn('battery empty (%s): motion stopped, commands dropped', state.cut_off)
            else:
                rospy.loginfo('battery no longer empty: relaying commands again')

    def _on_cmd_vel(self, twist):
        finite = all(math.isfinite(value) for value in (twist.linear.x, twist.linear.y, twist.linear.z,
                                                        twist.angular.x, twist.angular.y, twist.angular.z))
        with self._lock:
            if self._empty:
                return
            if finite:
                self._bad_command = False
                self._pub.publish(twist)
                return
            stop_now, self._bad_command = not self._bad_command, True
            if stop_now:   # once per run of bad commands: the motors stop rather than get NaN
                self._pub.publish(Twist())
        rospy.logwarn_throttle(10.0, 'a cmd_vel_in with a non-finite value (%s): sent a zero Twist instead',
                               ' '.join('%r' % v for v in (twist.linear.x, twist.linear.y, twist.linear.z,
                                                           twist.angular.x, twist.angular.y, twist.angular.z)))


def main():
    rospy.init_node('battery_cmd_vel_gate', disable_signals=True)   # node_signals.py's handlers (robot/__init__)
    CmdVelGate()
    rospy.spin()
