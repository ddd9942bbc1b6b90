"""The dock's charger contact (battery_dock_contact), without ROS: true while the robot stands within
``radius`` of the dock, slower than ``max_speed``, and is not leaving it; published on every change and every
REPEAT_PERIOD_S of ROS time (the front ends: ros1/dock_contact.py, ros2/dock_contact.py).

Leaving: once the contact has closed, a robot that drives away from the dock (moving, its distance growing)
is leaving it until it is out of the radius; it may pause on the way (its controller a few ticks late on a
loaded machine: the base stops at its cmd_vel timeout, 40-140 ms of wall time at sim_clock speed 240), and
the contact stays open. Before, the battery said "charger connected" and charged there about once a cycle
(issue 40 item 8); the rule after 87e33ef (close within 5 cm of the closest the robot came, anywhere in the
inner half) still closed it in 2 of 5 cycles of the ROS 2 demo at speed 240 under load, in the inner half.
A robot nudged towards the dock after a contact (its distance shrinking) is not leaving; one that has not
touched the contacts yet closes them wherever it stops within the radius.
"""
import math

from battery_simulator.core.node_settings import Setting
from battery_simulator.core.parameter_rules import is_number

REPEAT_PERIOD_S = 0.5   # ROS time between repeats of the contact (at least once a second)
GROWING_M = 1e-6        # a distance that grew by more than this between two poses: the robot moves away
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
        self._touched = False    # the contact closed since the robot entered the radius
        self._leaving = False    # it drove away from the dock since: no contact until it is out of the radius
        self._distance = None    # the last pose's distance to the dock, within the radius (None: outside)

    def update(self, x, y, linear_x, linear_y):
        """The contact after a pose and velocity: True/False when it changed, None when not, and
        ValueError (naming the values; the contact stands) for a non-finite position or speed."""
        speed = math.hypot(linear_x, linear_y)
        if not all(math.isfinite(value) for value in (x, y, speed)):
            raise ValueError('ignoring odometry with a non-finite position or speed (x %r, y %r, speed %r); '
                             'contact stays %s' % (x, y, speed, self.contact))
        distance = math.hypot(x - self._dock['dock_x'], y - self._dock['dock_y'])
        if distance > self._dock['radius']:
            self._touched = self._leaving = False
            self._distance = None
        else:
            if self._touched and speed >= self._dock['max_speed'] and self._distance is not None \
                    and distance > self._distance + GROWING_M:
                self._leaving = True
            self._distance = distance
        contact = in_contact(x, y, speed, **self._dock) and not self._leaving
        self._touched = self._touched or contact
        changed, self.contact = contact != self.contact, contact
        return contact if changed else None
