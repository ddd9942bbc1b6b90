"""A simulation clock (sim_clock): /clock running ``~speed`` times as fast as wall time.

It ticks ``~tick_hz`` times a second of wall time (default 1000, as Gazebo
does), each tick advancing ROS time by ``~speed / ~tick_hz`` (0.24 s at speed
240), so that every node under ``/use_sim_time`` (the battery, the robot, your
own) runs faster together: a sped-up demo spends on each trip the energy the
trip takes. ROS time is counted in ticks from ``~start``, so it never drifts
against itself; when the machine cannot keep up, the clock runs slower than
asked (as Gazebo's real-time factor drops) and says so.

With ``~wait_for`` the clock holds ROS time at ``~start`` until every topic
named there has a publisher (as Gazebo starts paused): the nodes of a sped-up
demo start in wall time, and a robot that boots in 2 s would otherwise find
its battery 480 s emptier at speed 240 than at speed 1.

:ROS Parameters:
  - ``~speed`` (float > 0, at most 10000): ROS seconds per wall second (default 1)
  - ``~start`` (float, 0 .. 4294967295 s): ROS time at the first tick (default 0); should the clock
    reach 4294967295 s (the largest a ROS time holds), it stops with one fatal line
  - ``~tick_hz`` (float, Hz, 0 < f <= 10000): ticks per wall second (default 1000)
  - ``~wait_for`` (list of topic names): hold ROS time until each has a publisher (default none)
  - ``~wait_timeout`` (float > 0, wall s): start anyway after this long, with a warning (default 60)

:Publishes:
  - ``/clock`` (rosgraph_msgs/Clock)
"""
import time

import rosgraph
import rospy
from rosgraph_msgs.msg import Clock

from battery_simulator.ros1.startup import StartupError, checked_param, exit_on_startup_error, init_node, is_number

BEHIND_S = 0.1   # further behind its wall schedule than this, the clock gives up catching up
HOLD_PERIOD_S = 0.1   # while holding: how often the held time is published and the master asked


def read_settings():
    return dict(
        speed=checked_param('~speed', 1.0, lambda v: is_number(v) and 0 < v <= 10000, 'a number in (0, 10000]'),
        start=checked_param('~start', 0.0, lambda v: is_number(v) and 0 <= v <= MAX_ROS_TIME_S,
                            'a number in [0, %d] s (a ROS time holds at most %d s)' % (MAX_ROS_TIME_S,
                                                                                      MAX_ROS_TIME_S)),
        tick_hz=checked_param('~tick_hz', 1000.0, lambda v: is_number(v) and 0 < v <= 10000,
                              'a number in (0, 10000] Hz'),
        wait_for=checked_param('~wait_for', [], _topic_names, 'a list of topic names'),
        wait_timeout=checked_param('~wait_timeout', 60.0, lambda v: is_number(v) and v > 0, 'a number > 0 s'),
    )


#: the largest whole second a ROS time holds (uint32 seconds)
MAX_ROS_TIME_S = 4294967295


def _topic_names(value):
    return isinstance(value, list) and all(isinstance(name, str) and name for name in value)


def missing_publishers(wanted, published):
    """The topics of ``wanted`` (resolved names) that no node publishes yet, given the master's list."""
    have = {topic for topic, _ in published}
    return [topic for topic in wanted if topic not in have]


def tick_time(start, speed, tick_hz, ticks):
    """ROS time (s) after ``ticks`` ticks: counted, not summed, so it never drifts."""
    return start + ticks * speed / tick_hz


class SimClock:
    def __init__(self, speed, start, tick_hz, wait_for=(), wait_timeout=60.0):
        self._speed, self._start, self._tick_hz = speed, start, tick_hz
        self._wait_for = [rospy.resolve_name(topic) for topic in wait_for]
        self._wait_timeout = wait_timeout
        self._pub = rospy.Publisher('/clock', Clock, queue_size=10)

    def _hold(self):
        """Publish ``~start`` until every ``~wait_for`` topic has a publisher (bounded, wall time)."""
        master = rosgraph.Master(rospy.get_name())
        deadline = time.monotonic() + self._wait_timeout
        missing = self._wait_for
        rospy.loginfo('sim_clock: holding ROS time at %g s until %s are published', self._start, ', '.join(missing))
        while missing and not rospy.is_shutdown():
            self._pub.publish(Clock(clock=rospy.Time.from_sec(self._start)))
            try:
                missing = missing_publishers(missing, master.getPublishedTopics('/'))
            except (OSError, rosgraph.MasterException) as error:   # a master restarting: ask again
                rospy.logwarn_throttle(10.0, 'sim_clock: cannot ask the master (%s)', error)
            if missing and time.monotonic() > deadline:
                rospy.logwarn('sim_clock: no publisher of %s after %g s: starting the clock anyway',
                              ', '.join(missing), self._wait_timeout)
                return
            if missing:
                time.sleep(HOLD_PERIOD_S)

    def spin(self):
        if self._wait_for:
            self._hold()
        rospy.loginfo('sim_clock: ROS time x%g from %g s, %g ticks a second of %g ms', self._speed, self._start,
                      self._tick_hz, 1000.0 * self._speed / self._tick_hz)
        period_s = 1.0 / self._tick_hz
        ticks, next_tick = 0, time.monotonic()
        while not rospy.is_shutdown():
            ticks += 1
            now = tick_time(self._start, self._speed, self._tick_hz, ticks)
            if now >= MAX_ROS_TIME_S:   # after 4.3e5 s (5 days) of wall time at the fastest speed from 0
                exit_on_startup_error(StartupError(
                    'sim_clock: ROS time reached %d s, the largest a ROS time holds: the clock stops (restart it '
                    'with a smaller ~start)' % MAX_ROS_TIME_S), stop_launch=False)
            self._pub.publish(Clock(clock=rospy.Time.from_sec(now)))
            next_tick += period_s
            delay_s = next_tick - time.monotonic()
            if delay_s > 0.0:
                time.sleep(delay_s)   # wall time: this node makes ROS time
            elif delay_s < -BEHIND_S:
                next_tick = time.monotonic()
                rospy.logwarn_throttle(10.0, 'sim_clock cannot keep up %g ticks a second: ROS time runs slower '
                                       'than x%g', self._tick_hz, self._speed)


def main():
    SimClock(**init_node('sim_clock', read_settings)).spin()
