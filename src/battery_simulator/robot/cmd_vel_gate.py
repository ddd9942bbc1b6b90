"""The cut-off gate's rule (battery_cmd_vel_gate), without ROS: no battery, no motion.

Commands pass while the battery is not Empty; at Empty one stop goes out and every command is dropped
until it is no longer Empty. A command with a NaN or infinite value is never relayed: a stop goes out
instead, once per run of bad commands. The front ends (ros1/cmd_vel_gate.py, ros2/cmd_vel_gate.py)
forward the message type they receive (geometry_msgs Twist or TwistStamped).
"""
import math

from battery_simulator.core.status_codes import EMPTY

FORWARD, STOP, DROP, BAD = 'forward', 'stop', 'drop', 'bad'


def twist_values(twist):
    """The six numbers of a Twist."""
    return (twist.linear.x, twist.linear.y, twist.linear.z, twist.angular.x, twist.angular.y, twist.angular.z)


class CmdVelGate:
    """Not thread-safe: the adapter serialises calls (and its publishing with them)."""

    def __init__(self):
        self.empty = False
        self._bad_command = False   # the last command was non-finite (a stop was sent for it)

    def on_state(self, charging_state):
        """The server's charging_state: 'empty' (stop now), 'not empty' (relay again) on a change, else None."""
        empty = charging_state == EMPTY
        changed, self.empty = empty != self.empty, empty
        if not changed:
            return None
        return 'empty' if empty else 'not empty'

    def on_command(self, values):
        """What to do with a command of these numbers: FORWARD it, send a STOP instead (the first bad one),
        DROP it (the battery is Empty), or drop a BAD one (a stop went out for an earlier one)."""
        if self.empty:
            return DROP
        if all(math.isfinite(value) for value in values):
            self._bad_command = False
            return FORWARD
        stop_now, self._bad_command = not self._bad_command, True
        return STOP if stop_now else BAD


def bad_command_line(values):
    return 'a cmd_vel_in with a non-finite value (%s): sent a zero Twist instead' % ' '.join('%r' % v for v in values)
