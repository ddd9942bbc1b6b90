"""The cut-off gate (battery_cmd_vel_gate): no battery, no motion.

Relays ``cmd_vel_in`` to ``cmd_vel_out`` while the battery can supply the
motors. When the server reports the pack Empty (its protection has cut the
load off) it publishes one zero Twist and drops every command until the
battery is no longer empty, as a real robot stops when its battery dies.
A command with a NaN or infinite value is never relayed: a zero Twist goes
out instead (once, until a finite command comes), with a log line.
The rule is robot/cmd_vel_gate.py's; it forwards the type it receives
(geometry_msgs/Twist or TwistStamped), and its stops are of that type.

:Subscribes:
  - ``cmd_vel_in`` (geometry_msgs/Twist or TwistStamped): the controller's commands
  - ``battery_simulator/state`` (battery_simulator/BatterySimState): from battery_sim_server.py
:Publishes:
  - ``cmd_vel_out`` (geometry_msgs/Twist, or TwistStamped once such commands come)
"""
import threading

import rospy

from battery_simulator.msg import BatterySimState
from battery_simulator.core import ros_names
from battery_simulator.robot import cmd_vel_gate as rule
from battery_simulator.ros1.twist import TwistPublisher, TwistSubscriber


class CmdVelGate:
    def __init__(self):
        self._lock = threading.Lock()   # guards _gate and the commands and stops published
        self._gate = rule.CmdVelGate()
        self._pub = TwistPublisher(ros_names.CMD_VEL_OUT, queue_size=10, like_topics=(ros_names.CMD_VEL_IN,))
        self._state_sub = rospy.Subscriber(ros_names.STATE_TOPIC, BatterySimState, self._on_state, queue_size=10)
        self._cmd_sub = TwistSubscriber(ros_names.CMD_VEL_IN, self._on_cmd_vel, queue_size=10)

    def _on_state(self, state):
        with self._lock:
            change = self._gate.on_state(state.charging_state)
            if change == 'empty':
                self._pub.publish_stop()   # the motors stop
        if change == 'empty':
            rospy.logwarn('battery empty (%s): motion stopped, commands dropped', state.cut_off)
        elif change == 'not empty':
            rospy.loginfo('battery no longer empty: relaying commands again')

    def _on_cmd_vel(self, twist, msg):
        values = rule.twist_values(twist)
        with self._lock:
            action = self._gate.on_command(values)
            if action == rule.FORWARD:
                self._pub.publish(msg)
            elif action == rule.STOP:   # once per run of bad commands: the motors stop rather than get NaN
                self._pub.publish_stop(like=msg)
        if action in (rule.STOP, rule.BAD):
            rospy.logwarn_throttle(10.0, rule.bad_command_line(values))


def main():
    rospy.init_node('battery_cmd_vel_gate', disable_signals=True)   # node_signals.py's handlers (ros1/__init__)
    CmdVelGate()
    rospy.spin()
