"""``battery_cmd_vel_gate`` (ROS 2): the cut-off gate, as ROS 1's battery_cmd_vel_gate.py: no battery, no motion.

Relays ``cmd_vel_in`` to ``cmd_vel_out`` (geometry_msgs/msg/Twist or TwistStamped: the type it receives)
while the battery can supply the motors; when ``battery_simulator/state`` says Empty it publishes one zero
command and drops every command until the battery is no longer empty. A command with a NaN or infinite
value is never relayed: a zero command goes out instead, once per run of them, with a log line
(robot/cmd_vel_gate.py). Remap ``cmd_vel_in`` and ``cmd_vel_out`` with ``-r``.
"""
from battery_simulator.core import ros_names
from battery_simulator.msg import BatterySimState
from battery_simulator.robot import cmd_vel_gate as rule
from battery_simulator.ros2.qos import LATCHED_QOS
from battery_simulator.ros2.startup import run_node
from battery_simulator.ros2.twist import TwistPublisher, TwistSubscriber


class CmdVelGate:
    def __init__(self, node, cmd_vel_in=ros_names.CMD_VEL_IN, cmd_vel_out=ros_names.CMD_VEL_OUT):
        self._node = node
        self._gate = rule.CmdVelGate()
        self._pub = TwistPublisher(node, cmd_vel_out)
        self._state_sub = node.create_subscription(BatterySimState, ros_names.STATE_TOPIC, self._on_state, LATCHED_QOS)
        self._cmd_sub = TwistSubscriber(node, cmd_vel_in, self._on_cmd_vel)

    def _on_state(self, state):
        change = self._gate.on_state(state.charging_state)
        if change == 'empty':
            self._pub.publish_stop()   # the motors stop
            self._node.get_logger().warning('battery empty (%s): motion stopped, commands dropped' % state.cut_off)
        elif change == 'not empty':
            self._node.get_logger().info('battery no longer empty: relaying commands again')

    def _on_cmd_vel(self, twist, msg):
        values = rule.twist_values(twist)
        action = self._gate.on_command(values)
        if action == rule.FORWARD:
            self._pub.publish(msg)
        elif action == rule.STOP:   # once per run of bad commands: the motors stop rather than get NaN
            self._pub.publish_stop(like=msg)
        if action in (rule.STOP, rule.BAD):
            self._node.get_logger().warning(rule.bad_command_line(values), throttle_duration_sec=10.0)


def main(args=None):
    run_node('battery_cmd_vel_gate', (), CmdVelGate, args)
