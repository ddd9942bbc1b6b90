"""The cut-off gate (battery_cmd_vel_gate): no battery, no motion.

Relays ``cmd_vel_in`` to ``cmd_vel_out`` while the battery can supply the
motors. When the server reports the pack Empty (its protection has cut the
load off) it publishes one zero Twist and drops every command until the
battery is no longer empty, as a real robot stops when its battery dies.

:Subscribes:
  - ``cmd_vel_in`` (geometry_msgs/Twist): the controller's commands
  - ``battery_simulator/state`` (battery_simulator/BatterySimState): from battery_sim_server.py
:Publishes:
  - ``cmd_vel_out`` (geometry_msgs/Twist)
"""
import threading

import rospy
from geometry_msgs.msg import Twist

from battery_simulator.msg import BatterySimState
from battery_simulator.ros import topics


class CmdVelGate:
    def __init__(self):
        self._lock = threading.Lock()   # guards _empty and the stop published on a cut-off
        self._empty = False
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
        with self._lock:
            if not self._empty:
                self._pub.publish(twist)


def main():
    rospy.init_node('battery_cmd_vel_gate')
    CmdVelGate()
    rospy.spin()
