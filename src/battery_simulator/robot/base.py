"""The kinematic base's rule (fake_base), without ROS: integrate the latest command over the ROS time
that actually passed, exactly for a held command, and stop at the command's timeout.

Each front end (ros1/fake_base.py, ros2/fake_base.py) feeds it commands and ROS times and publishes
the pose it returns as odometry and tf.
"""
import collections
import math

from battery_simulator.core.node_settings import Setting
from battery_simulator.core.parameter_rules import is_number

#: fake_base's parameters (ROS 1: ~name; ROS 2: declared)
SETTINGS = (
    Setting('rate', 20.0, lambda v: is_number(v) and 0 < v <= 1000, 'a number in (0, 1000] Hz',
            'integration and publication rate (ROS time), Hz', False),
    Setting('x', 0.0, is_number, 'a number (m)', 'start pose x, m', False),
    Setting('y', 0.0, is_number, 'a number (m)', 'start pose y, m', False),
    Setting('yaw', 0.0, is_number, 'a number (rad)', 'start pose yaw, rad', False),
    Setting('cmd_vel_timeout', 0.5, lambda v: is_number(v) and v > 0, 'a number > 0 s',
            'a command older than this (ROS time) counts as stop, s', False),
    Setting('odom_frame', 'odom', lambda v: isinstance(v, str) and v != '', 'a frame id', 'odometry frame', False),
    Setting('base_frame', 'base_footprint', lambda v: isinstance(v, str) and v != '', 'a frame id',
            'the robot base frame', False),
)
STEPS_SEEN = 20   # how many recent steps of ROS time give the clock's tick


def integrate(x, y, yaw, linear, angular, dt_s):
    """The pose after driving at (linear, angular) for dt_s (exact arc for a unicycle)."""
    if abs(angular) < 1e-9:
        return x + linear * dt_s * math.cos(yaw), y + linear * dt_s * math.sin(yaw), yaw
    new_yaw = yaw + angular * dt_s
    radius = linear / angular
    return (x + radius * (math.sin(new_yaw) - math.sin(yaw)),
            y - radius * (math.cos(new_yaw) - math.cos(yaw)),
            math.atan2(math.sin(new_yaw), math.cos(new_yaw)))


def advance(pose, command, last_s, now_s, timeout_s):
    """(pose, moving) after the ROS time from ``last_s`` to ``now_s``: ``command`` = (linear, angular,
    received_s) drives from ``last_s`` until it times out (exact: one arc), then the base stands."""
    linear, angular, received_s = command
    moving_s = min(now_s, received_s + timeout_s) - last_s
    if moving_s <= 0.0:
        return pose, False
    return integrate(*pose, linear, angular, moving_s), now_s - received_s <= timeout_s


def yaw_quaternion(yaw):
    """(x, y, z, w) of a rotation by ``yaw`` about z."""
    return 0.0, 0.0, math.sin(yaw / 2.0), math.cos(yaw / 2.0)


def finite_command(linear, angular):
    return math.isfinite(linear) and math.isfinite(angular)


class Base:
    """The pose of a kinematic base over ROS time. Not thread-safe: the adapter serialises calls."""

    def __init__(self, x=0.0, y=0.0, yaw=0.0, cmd_vel_timeout=0.5):
        self.pose = (x, y, yaw)
        self._timeout_s = cmd_vel_timeout
        self._steps = collections.deque(maxlen=STEPS_SEEN)   # the last steps of ROS time seen (s): the tick
        self._command = (0.0, 0.0, -math.inf)   # (linear, angular, ROS time received)
        self.time_s = 0.0   # the ROS time integrated to

    def command(self, linear, angular, now_s):
        """A new command at ROS time ``now_s``; False (ignored) when a value is not finite."""
        if not finite_command(linear, angular):
            return False
        self._command = (linear, angular, now_s)
        return True

    def step(self, now_s):
        """Advance to ROS time ``now_s``: (pose, (linear, angular) moving now) to publish, or None when ROS
        time has not moved (a coarse clock may wake the loop twice a tick). A clock jump back, or no clock
        yet (0), restarts from here without moving."""
        last_s = self.time_s
        if now_s < last_s or last_s == 0.0:
            last_s = now_s
        elif now_s == last_s:
            return None
        if now_s > last_s:
            self._steps.append(now_s - last_s)
        # a command holds for its timeout, or one and a half ticks of a coarse clock (the shortest
        # recent step), never for a stall's whole length
        timeout_s = max(self._timeout_s, 1.5 * min(self._steps, default=0.0))
        self.pose, moving = advance(self.pose, self._command, last_s, now_s, timeout_s)
        self.time_s = now_s
        return self.pose, (self._command[:2] if moving else (0.0, 0.0))
