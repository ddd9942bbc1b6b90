"""sim_clock's tick policy, without ROS: ROS time counted in ticks from ``start`` (never drifting), a tick
every 1 / ``tick_hz`` wall seconds, catching up when late by less than BEHIND_S and giving up (the clock
runs slower than asked, as Gazebo's real-time factor drops) beyond it; the hold until named topics
have publishers; and the pace: each tick waits (bounded) for a message on each ``pace_on`` topic. The
front ends: ros1/sim_clock.py, ros2/sim_clock.py (and battery_demo's clock).

The pace (issue 40 items 8 and 15): at speed 240 a wall millisecond is 0.24 s of ROS time. On a busy
machine the robot's controller gets the CPU a few milliseconds late, the base's command times out in ROS
time, and the robot stands while the clock runs on: the ROS 1 demo docked 5.2 points under its low level
(44.8 % against 50 %, with two CPU hogs), and a base stopped for a tick inside the dock's radius closed
the contact. Paced on the robot's cmd_vel, ROS time moves a tick only once the controller answered the
last one (at most PACE_WAIT_S of wall time: a controller that died does not stop the world).
"""
from battery_simulator.core.node_settings import Setting, is_topic_name
from battery_simulator.core.parameter_rules import is_number

BEHIND_S = 0.1   # further behind its wall schedule than this, the clock gives up catching up
PACE_WAIT_S = 0.5   # the longest a tick waits for the pace_on topics (wall s)
HOLD_PERIOD_S = 0.1   # while holding: how often the held time is published and the graph asked
#: the largest whole second a ROS time holds (uint32 seconds)
MAX_ROS_TIME_S = 4294967295


def _topic_names(value):
    return isinstance(value, (list, tuple)) and all(is_topic_name(name) for name in value)


SETTINGS = (
    Setting('speed', 1.0, lambda v: is_number(v) and 0 < v <= 10000, 'a number in (0, 10000]',
            'ROS seconds per wall second', False),
    Setting('start', 0.0, lambda v: is_number(v) and 0 <= v <= MAX_ROS_TIME_S,
            'a number in [0, %d] s (a ROS time holds at most %d s)' % (MAX_ROS_TIME_S, MAX_ROS_TIME_S),
            'ROS time at the first tick, s', False),
    Setting('tick_hz', 1000.0, lambda v: is_number(v) and 0 < v <= 10000, 'a number in (0, 10000] Hz',
            'ticks per wall second', False),
    Setting('wait_for', [], _topic_names, 'a list of topic names',
            'hold ROS time at start until each of these topics has a publisher', False),
    Setting('wait_timeout', 60.0, lambda v: is_number(v) and v > 0, 'a number > 0 s',
            'start anyway after this long (wall s), with a warning', False),
    Setting('pace_on', [], _topic_names, 'a list of topic names',
            'each tick waits (at most %g s of wall time) for a message on each of these topics since the last '
            'one (the robot\'s cmd_vel: ROS time never runs ahead of the controller)' % PACE_WAIT_S, False),
)


class Pace:
    """Which ``pace_on`` topics sent a message since the last tick: ``ticked()`` after each tick,
    ``heard(topic)`` on each message, ``ready()`` once every topic was heard (or there is none)."""

    def __init__(self, topics):
        self.topics = list(topics)
        self._heard = set(self.topics)   # the first tick waits for nothing

    def ticked(self):
        self._heard = set()

    def heard(self, topic):
        self._heard.add(topic)

    def ready(self):
        return self._heard.issuperset(self.topics)


def tick_time(start, speed, tick_hz, ticks):
    """ROS time (s) after ``ticks`` ticks: counted, not summed, so it never drifts."""
    return start + ticks * speed / tick_hz


def missing_publishers(wanted, published):
    """The topics of ``wanted`` (resolved names) that no node publishes yet, given [(topic, type)] published."""
    have = {topic for topic, _ in published}
    return [topic for topic in wanted if topic not in have]


class ClockTooFar(Exception):
    """ROS time reached MAX_ROS_TIME_S: the clock stops."""


def too_far_line(start_name):
    return ('sim_clock: ROS time reached %d s, the largest a ROS time holds: the clock stops (restart it '
            'with a smaller %s)' % (MAX_ROS_TIME_S, start_name))


class TickSchedule:
    """The ticks of a clock: ``tick()`` is the next ROS time to publish, then ``delay(wall_now)`` the wall
    seconds to sleep until the tick after, and whether the clock gave up catching up on it."""

    def __init__(self, speed, start, tick_hz, wall_now, paced_on=()):
        """``paced_on``: the topics each tick waits for (a clock paced on the robot's controller)."""
        self.speed, self.start, self.tick_hz = speed, start, tick_hz
        self.paced_on = list(paced_on)
        self.period_s = 1.0 / tick_hz
        self.ticks = 0
        self._next_wall = wall_now

    def tick(self):
        """The ROS time of the next tick; ClockTooFar at MAX_ROS_TIME_S (after 4.3e5 s, 5 days, of wall time
        at the fastest speed from 0)."""
        self.ticks += 1
        now = tick_time(self.start, self.speed, self.tick_hz, self.ticks)
        if now >= MAX_ROS_TIME_S:
            raise ClockTooFar()
        return now

    def delay(self, wall_now):
        """(wall seconds to sleep before the next tick, behind): behind more than BEHIND_S, the schedule
        restarts from now (ROS time runs slower than asked) and behind is True."""
        self._next_wall += self.period_s
        delay_s = self._next_wall - wall_now
        if delay_s < -BEHIND_S:
            self._next_wall = wall_now
            return 0.0, True
        return max(0.0, delay_s), False

    def behind_line(self):
        if self.paced_on:   # expected: each tick waits for the robot's controller
            return 'sim_clock paced on %s: ROS time runs slower than x%g while the controller takes longer than a ' \
                   'tick (%g ms)' % (', '.join(self.paced_on), self.speed, 1000.0 / self.tick_hz)
        return 'sim_clock cannot keep up %g ticks a second: ROS time runs slower than x%g' % (self.tick_hz, self.speed)

    def start_line(self):
        return 'sim_clock: ROS time x%g from %g s, %g ticks a second of %g ms' % (
            self.speed, self.start, self.tick_hz, 1000.0 * self.speed / self.tick_hz)
