"""The dock's charger contact (battery_dock_contact), without ROS: true while the robot stands within
``radius`` of the dock, slower than ``max_speed``, and has not backed off from where it stood closest;
published on every change and every REPEAT_PERIOD_S of ROS time (the front ends: ros1/dock_contact.py,
ros2/dock_contact.py).

A robot leaving the dock that pauses within the radius (its controller a few ticks late on a loaded
machine: the base stops at its cmd_vel timeout, 40-140 ms of wall time at sim_clock speed 240) is not
on the contacts any more: before, the battery said "charger connected" and charged there once a cycle
(issue 40). So in the outer half of the radius the contact closes only within LEAVING_M of the closest
the robot came since it entered the radius.
"""
import math

from battery_simulator.core.node_settings import Setting
from battery_simulator.core.parameter_rules import is_number

REPEAT_PERIOD_S = 0.5   # ROS time between repeats of the contact (at least once a second)
LEAVING_M = 0.05        # farther than this from the closest it came within the radius: the robot is leaving
INNER = 0.5             # within this fraction of the radius the robot stands on the dock whatever it did (the
                        # demo parks within half of it: one that passed the centre still charges)
SETTINGS = (
    Setting('dock_x', 0.0, is_number, 'a number (m)', 'the dock in the odom frame, x (m)', False),
    Setting('dock_y', 0.0, is_number, 'a number (m)', 'the dock in the odom frame, y (m)', False),
    Setting('radius', 0.3, lambda v: is_number(v) and v > 0, 'a number > 0 m', 'contact within this distance, m',
            False),
    Setting('max_speed', 0.05, lambda v: is_number(v) and v > 0, 'a number > 0 m/s',
            'and slower than this, m/s', False),
)


def in_contact(x, y, speed, dock_x, dock_y, radius, max_speed):
    """Whether a robot at (x, y) moving at ``speed`` touches the dock's contacts."""
    return math.hypot(x - dock_x, y - dock_y) <= radius and speed < max_speed


class DockContact:
    """The contact state from odometry. Not thread-safe: the adapter serialises calls."""

    def __init__(self, dock_x, dock_y, radius, max_speed):
        self._dock = dict(dock_x=dock_x, dock_y=dock_y, radius=radius, max_speed=max_speed)
        self.contact = False
        self._closest_m = math.inf   # the closest the robot came to the dock since it entered the radius

    def update(self, x, y, linear_x, linear_y):
        """The contact after a pose and velocity: True/False when it changed, None when not, and
        ValueError (naming the values; the contact stands) for a non-finite position or speed."""
        speed = math.hypot(linear_x, linear_y)
        if not all(math.isfinite(value) for value in (x, y, speed)):
            raise ValueError('ignoring odometry with a non-finite position or speed (x %r, y %r, speed %r); '
                             'contact stays %s' % (x, y, speed, self.contact))
        distance = math.hypot(x - self._dock['dock_x'], y - self._dock['dock_y'])
        self._closest_m = min(self._closest_m, distance) if distance <= self._dock['radius'] else math.inf
        contact = in_contact(x, y, speed, **self._dock) and (distance <= INNER * self._dock['radius'] or
                                                             distance <= self._closest_m + LEAVING_M)
        changed, self.contact = contact != self.contact, contact
        return contact if changed else None
