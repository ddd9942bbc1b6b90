"""The dock's charger contact (battery_dock_contact), without ROS: true while the robot stands within
``radius`` of the dock, slower than ``max_speed``, and is not leaving it; published on every change and every
REPEAT_PERIOD_S of ROS time (the front ends: ros1/dock_contact.py, ros2/dock_contact.py).

Leaving: once the contact has closed, a robot that moves more than LEAVING_M from where it touched (in any
direction), or drives away from the dock (moving, its distance growing), is leaving the dock until it is out
of the radius; it may pause on the way (its controller a few
ticks late on a loaded machine: the base stops at its cmd_vel timeout, 40-140 ms of wall time at sim_clock
speed 240), and the contact stays open. Before, the battery said "charger connected" and charged there about
once a cycle (issue 40 item 8). Measured on the real demo (ROS 2 battery_demo at speed 240, load 20-30): the
rule of 87e33ef (close within 5 cm of the closest the robot came, anywhere in the inner half) closed it away
from the dock in 2 of 5 cycles; "leaving = driving away, its distance growing" in 3 of 4 (a robot that
docked turned sideways backs off past the centre: its distance first shrinks). A robot nudged by less than
LEAVING_M after a contact connects again; one that has not touched the contacts yet closes them wherever
it stops within the radius.
"""
import math

from battery_simulator.core.node_settings import Setting
from battery_simulator.core.parameter_rules import is_number

REPEAT_PERIOD_S = 0.5   # ROS time between repeats of the contact (at least once a second)
LEAVING_M = 0.05        # moved farther than this from where it touched the contacts: the robot is leaving
GROWING_M = 1e-6        # or moving, its distance to the dock grown by more than this since the last pose
RADIUS_M = 0.3          # the contact radius by default
#: the inner half of the radius is the dock itself (patrol_and_dock stops 0.15 m from it): a touch farther out
#: is a stop on the way in, and a contact there while undocking is away from the dock (the demo tests)
AT_DOCK_FRACTION = 0.5
SETTINGS = (
    Setting('dock_x', 0.0, is_number, 'a number (m)', 'the dock in the odom frame, x (m)', False),
    Setting('dock_y', 0.0, is_number, 'a number (m)', 'the dock in the odom frame, y (m)', False),
    Setting('radius', RADIUS_M, lambda v: is_number(v) and v > 0, 'a number > 0 m', 'contact within this distance, m',
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
        self._touched = None     # where the contact closed since the robot entered the radius (x, y)
        self._touched_distance = None   # ... and its distance to the dock
        self._leaving = False    # it moved LEAVING_M away from there since: no contact until out of the radius
        self._distance = None    # the last pose's distance to the dock (within the radius)

    def update(self, x, y, linear_x, linear_y):
        """The contact after a pose and velocity: True/False when it changed, None when not, and
        ValueError (naming the values; the contact stands) for a non-finite position or speed."""
        speed = math.hypot(linear_x, linear_y)
        if not all(math.isfinite(value) for value in (x, y, speed)):
            raise ValueError('ignoring odometry with a non-finite position or speed (x %r, y %r, speed %r); '
                             'contact stays %s' % (x, y, speed, self.contact))
        distance = math.hypot(x - self._dock['dock_x'], y - self._dock['dock_y'])
        if distance > self._dock['radius']:
            self._touched, self._leaving, self._distance = None, False, None
            return self._set(False)
        if self._touched is not None and self._touched_distance > AT_DOCK_FRACTION * self._dock['radius'] \
                and distance < self._touched_distance - LEAVING_M:
            # touched in the outer half (a stall on its way to the dock) and now closer in: approaching, not
            # leaving; without this the robot never got the contact at the dock, and the ROS 2 demo stayed in
            # GO_TO_DOCK (a robot that backs off its dock across the centre touched in the inner half: leaving)
            self._touched, self._touched_distance, self._leaving = (x, y), distance, False
        elif self._touched is not None and (
                math.hypot(x - self._touched[0], y - self._touched[1]) > LEAVING_M
                or (speed >= self._dock['max_speed'] and distance > self._distance + GROWING_M)):
            self._leaving = True
        self._distance = distance
        contact = in_contact(x, y, speed, **self._dock) and not self._leaving
        if contact and self._touched is None:
            self._touched, self._touched_distance = (x, y), distance
        return self._set(contact)

    def _set(self, contact):
        changed, self.contact = contact != self.contact, contact
        return contact if changed else None
