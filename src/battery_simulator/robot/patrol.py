"""The demo behaviour's rule (patrol_and_dock), without ROS: patrol a loop of waypoints, drive to the dock
when the battery is low, charge on contact (standing on the dock DOCK_RETRY_S without it: back off and come
again), back off the dock when full (after resting there ``rest_on_dock`` seconds), patrol again.

``Patrol.control`` is one control step: the pose, the inputs and the ROS time a command holds in, the
(linear, angular) command out; no command drives or turns past its goal within one step. The front ends
(ros1/patrol_and_dock.py, ros2/patrol_and_dock.py) give it the inputs, send the charge goal it asks for,
tell it how the goal ended, log and publish each phase.
"""
import math

from battery_simulator.core.node_settings import Setting
from battery_simulator.core.parameter_rules import is_number
from battery_simulator.core.server_log import SHUTDOWN_TEXT

PATROL, GO_TO_DOCK, CHARGING, UNDOCK = 'PATROL', 'GO_TO_DOCK', 'CHARGING', 'UNDOCK'
PHASES = (PATROL, GO_TO_DOCK, CHARGING, UNDOCK)
CONTROL_RATE_HZ = 20.0
ARRIVED_M = 0.08          # a waypoint counts as reached within this distance (or half a step's drive)
DOCKED_M = 0.15           # stop this close to the dock: well inside battery_dock_contact's radius (0.3 m)
#: standing on the dock this long (ROS time, s) without the contact: back off ``undock_distance`` (out of the
#: contact's radius) and come again. The contact closes a step or two after the robot stops; a robot that crossed
#: the dock on its way in (a late controller) is "leaving" to battery_dock_contact until it is out of the radius,
#: and stood there for good: the ROS 2 demo at speed 240 under two CPU hogs ran its battery empty on the dock
DOCK_RETRY_S = 10.0
MAX_TURN_RADPS = 1.5
DEFAULT_WAYPOINTS = [[1.0, 0.0], [2.0, 0.0], [2.0, 2.0], [0.0, 2.0], [0.0, 0.8]]
#: the same as ROS 2 takes it (its parameters hold no list of lists)
DEFAULT_WAYPOINTS_FLAT = [c for point in DEFAULT_WAYPOINTS for c in point]
#: how a charge goal ended, as the front end tells it
GOAL_SUCCEEDED, GOAL_FAILED = 'succeeded', 'failed'


def goal_failed_line(state_name, text):
    """(is it a warning, the line) for a charge goal that ended otherwise than Full, sent again: a server that
    shuts down (a launch's Ctrl-C, a respawn) is information, said in words, not an actionlib state number."""
    if SHUTDOWN_TEXT in text:
        return False, 'the battery server is shutting down (%s): the charge goal is sent again when it is back' % text
    return True, 'charge goal ended %s (%s): sending it again' % (state_name, text)


def waypoint_pairs(value):
    """[(x, y)] of a list of [x, y] points, or of a flat list x1, y1, x2, y2 ... (ROS 2 parameters hold no
    list of lists); None when it is neither (or empty)."""
    if isinstance(value, (str, bytes, dict)) or not hasattr(value, '__len__') or not value:
        return None
    value = list(value)   # rclpy gives a double array as array.array
    if all(isinstance(p, (list, tuple)) and len(p) == 2 and all(is_number(c) for c in p) for p in value):
        return [(float(p[0]), float(p[1])) for p in value]
    if len(value) % 2 == 0 and all(is_number(c) for c in value):
        return [(float(value[i]), float(value[i + 1])) for i in range(0, len(value), 2)]
    return None


SETTINGS = (
    Setting('waypoints', DEFAULT_WAYPOINTS, lambda v: waypoint_pairs(v) is not None,
            'a list of [x, y] points (m)', 'the patrol loop, m', False),
    Setting('dock_x', 0.0, is_number, 'a number (m)', 'the dock, x (m), as battery_dock_contact has it', False),
    Setting('dock_y', 0.0, is_number, 'a number (m)', 'the dock, y (m)', False),
    Setting('speed', 0.3, lambda v: is_number(v) and v > 0, 'a number > 0 m/s', 'cruising speed, m/s', False),
    Setting('undock_distance', 0.6, lambda v: is_number(v) and v > 0, 'a number > 0 m',
            'how far to back off the dock (when full, or to dock again without a contact), m', False),
    Setting('rest_on_dock', 0.0, lambda v: is_number(v) and 0 <= v <= 86400, 'a number in [0, 86400] s',
            'how long to stay on the dock once full (ROS time, s): the charger carries the robot, the pack '
            'rests (a fuel gauge reads its rest there)', False),
)


def drive_to(x, y, yaw, goal_x, goal_y, speed, step_s=1.0 / CONTROL_RATE_HZ):
    """(linear, angular) to drive a unicycle at (x, y, yaw) to the goal: turn first, then go, slowing near it.

    ``step_s`` is the ROS time a command holds before the next (0.24 s under sim_clock at speed 240): no
    command drives or turns more than half the way left within one step, so it never overshoots, even
    acting on a pose one step old (the base and this node take turns on each tick).
    """
    distance = math.hypot(goal_x - x, goal_y - y)
    heading_error = math.atan2(goal_y - y, goal_x - x) - yaw
    heading_error = math.atan2(math.sin(heading_error), math.cos(heading_error))
    turn_limit = min(MAX_TURN_RADPS, 0.5 * abs(heading_error) / step_s)
    angular = max(-turn_limit, min(turn_limit, 2.5 * heading_error))
    linear = 0.0 if abs(heading_error) > 0.5 else \
        min(speed, 1.2 * distance, 0.5 * distance / step_s) * math.cos(heading_error)
    return linear, angular


def back_to(x, y, yaw, goal_x, goal_y, speed, step_s=1.0 / CONTROL_RATE_HZ):
    """(linear, angular) to back a unicycle at (x, y, yaw) to the goal: drive_to with the robot's rear as its
    front (turn first, then reverse)."""
    linear, angular = drive_to(x, y, yaw + math.pi, goal_x, goal_y, speed, step_s)
    return -linear, angular


def undock_goal(x, y, yaw, dock_x, dock_y, distance_m, toward):
    """Where to back off the dock to: ``distance_m`` from the dock towards ``toward`` (the first waypoint, where
    the patrol goes on), so that the way on never crosses the dock; away from the dock, or straight back,
    when ``toward`` is the dock. Backing along the robot's heading (or away from the dock, from where it
    stood) took a robot that had turned on the dock, or stopped past its centre, to the dock's far side, and
    the patrol back to the first waypoint crossed the contact's radius and closed it there (issue 40 item 8:
    the ROS 2 demo at speed 240 under load, 6-7 contacts on patrol in 4 cycles)."""
    ahead_x, ahead_y = toward[0] - dock_x, toward[1] - dock_y
    norm = math.hypot(ahead_x, ahead_y)
    if norm < 1e-3:
        ahead_x, ahead_y = x - dock_x, y - dock_y
        norm = math.hypot(ahead_x, ahead_y)
    if norm < 1e-3:
        ahead_x, ahead_y, norm = -math.cos(yaw), -math.sin(yaw), 1.0
    return dock_x + distance_m * ahead_x / norm, dock_y + distance_m * ahead_y / norm


def control_step(last_s, now_s):
    """The ROS time a command sent now holds (s), or None when no step is due: ROS time has not moved (a
    coarse clock may wake the loop twice a tick). A jump back of more than a second restarts it."""
    if now_s > last_s:
        return max(1.0 / CONTROL_RATE_HZ, now_s - last_s)
    if now_s < last_s - 1.0:
        return 1.0 / CONTROL_RATE_HZ
    return None


def yaw_of(z, w):
    """Yaw of a quaternion that rotates about z only."""
    return 2.0 * math.atan2(z, w)


class Patrol:
    """The phase machine. ``on_phase(phase)`` logs and publishes a phase; ``send_charge_goal()`` sends the
    charge goal (its end comes back as control's ``goal_outcome``). Not thread-safe."""

    def __init__(self, waypoints, dock_x, dock_y, speed, undock_distance, on_phase, send_charge_goal,
                 rest_on_dock=0.0):
        self.waypoints = waypoint_pairs(waypoints)
        self.dock = (dock_x, dock_y)
        self.speed = speed
        self.undock_distance = undock_distance
        self.rest_on_dock = rest_on_dock
        self.rested_s = None   # since the charge goal ended Full (None: not full yet)
        self._on_phase = on_phase
        self._send_charge_goal = send_charge_goal
        self.phase = None
        self.next_waypoint = 0
        self.undock_from = None   # UNDOCK's goal (undock_goal)
        self.on_dock_s = 0.0      # GO_TO_DOCK: how long the robot has stood on the dock without the contact
        self.dock_again_from = None   # GO_TO_DOCK: where it backs off to before coming again (DOCK_RETRY_S)

    def enter(self, phase):
        self.phase = phase
        self._on_phase(phase)

    def start(self):
        self.enter(PATROL)

    def control(self, pose, low, contact, step_s, goal_outcome=None):
        """One control step: (linear, angular). ``goal_outcome``: None while the charge goal runs (or there is
        none), GOAL_SUCCEEDED when it ended "Full", GOAL_FAILED when it ended otherwise (sent again)."""
        x, y, yaw = pose
        if self.phase == PATROL:
            if low:
                self.on_dock_s, self.dock_again_from = 0.0, None
                self.enter(GO_TO_DOCK)
                return 0.0, 0.0
            goal = self.waypoints[self.next_waypoint]
            if math.hypot(goal[0] - x, goal[1] - y) < max(ARRIVED_M, 0.5 * self.speed * step_s):
                self.next_waypoint = (self.next_waypoint + 1) % len(self.waypoints)
            return drive_to(x, y, yaw, goal[0], goal[1], self.speed, step_s)
        if self.phase == GO_TO_DOCK:
            if contact:
                self._send_charge_goal()
                self.enter(CHARGING)
                return 0.0, 0.0
            if self.dock_again_from is not None:   # no contact on the dock: backing off before coming again
                if math.hypot(self.dock_again_from[0] - x, self.dock_again_from[1] - y) >= ARRIVED_M:
                    return back_to(x, y, yaw, self.dock_again_from[0], self.dock_again_from[1], 0.5 * self.speed,
                                   step_s)
                self.dock_again_from = None
            if math.hypot(self.dock[0] - x, self.dock[1] - y) < DOCKED_M:
                self.on_dock_s += step_s   # on the dock: stand still until the contact closes
                if self.on_dock_s >= DOCK_RETRY_S:
                    self.on_dock_s = 0.0
                    self.dock_again_from = undock_goal(x, y, yaw, self.dock[0], self.dock[1], self.undock_distance,
                                                       self.waypoints[0])
                return 0.0, 0.0
            self.on_dock_s = 0.0
            return drive_to(x, y, yaw, self.dock[0], self.dock[1], self.speed, step_s)
        if self.phase == CHARGING:
            if goal_outcome == GOAL_SUCCEEDED and self.rested_s is None:   # told again at every step: once
                self.rested_s = 0.0
            elif goal_outcome == GOAL_FAILED:
                self._send_charge_goal()
            if self.rested_s is not None:   # full: rest on the dock rest_on_dock seconds, then undock
                if self.rested_s >= self.rest_on_dock:
                    self.rested_s = None
                    self.undock_from = undock_goal(x, y, yaw, self.dock[0], self.dock[1], self.undock_distance,
                                                   self.waypoints[0])
                    self.enter(UNDOCK)
                else:
                    self.rested_s += step_s
            return 0.0, 0.0
        # UNDOCK: back off the dock towards the first waypoint's side (undock_goal), then patrol from it (within
        # ARRIVED_M: halving what is left each step would otherwise never get there)
        left_m = math.hypot(self.undock_from[0] - x, self.undock_from[1] - y)
        if left_m < ARRIVED_M:
            self.next_waypoint = 0
            self.enter(PATROL)
            return 0.0, 0.0
        return back_to(x, y, yaw, self.undock_from[0], self.undock_from[1], 0.5 * self.speed, step_s)
