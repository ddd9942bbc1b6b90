"""A simulation clock (sim_clock): /clock running ``~speed`` times as fast as wall time.

It ticks ``~tick_hz`` times a second of wall time (default 1000, as Gazebo
does), each tick advancing ROS time by ``~speed / ~tick_hz`` (0.24 s at speed
240), so that every node under ``/use_sim_time`` (the battery, the robot, your
own) runs faster together: a sped-up demo spends on each trip the energy the
trip takes. ROS time is counted in ticks from ``~start``, so it never drifts
against itself; when the machine cannot keep up, the clock runs slower than
asked (as Gazebo's real-time factor drops) and says so (the tick policy:
robot/clock.py).

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
  - ``~pace_on`` (list of topic names): each tick waits, at most 0.5 s of wall time, for a message on each
    since the last tick (demo.launch: the robot's cmd_vel; robot/clock.py's Pace)

:Publishes:
  - ``/clock`` (rosgraph_msgs/Clock)
"""
import threading
import time

import rosgraph
import rospy
from rosgraph_msgs.msg import Clock

from battery_simulator.core import ros_names
from battery_simulator.robot import clock as rule
from battery_simulator.robot.clock import missing_publishers
from battery_simulator.ros1.startup import StartupError, exit_on_startup_error, init_node, read_private_settings


def read_settings():
    return read_private_settings(rule.SETTINGS)


class SimClock:
    def __init__(self, speed, start, tick_hz, wait_for=(), wait_timeout=60.0, pace_on=()):
        self._speed, self._start, self._tick_hz = speed, start, tick_hz
        self._wait_for = [rospy.resolve_name(topic) for topic in wait_for]
        self._wait_timeout = wait_timeout
        self._pub = rospy.Publisher(ros_names.CLOCK, Clock, queue_size=10)
        self._pace = rule.Pace(rospy.resolve_name(topic) for topic in pace_on)
        self._paced = threading.Condition()
        self._pace_subs = [rospy.Subscriber(topic, rospy.AnyMsg, self._on_pace, callback_args=topic, queue_size=10)
                           for topic in self._pace.topics]

    def _on_pace(self, _msg, topic):
        with self._paced:
            self._pace.heard(topic)
            self._paced.notify_all()

    def _wait_for_pace(self):
        """Until every pace_on topic sent a message since the last tick (bounded, wall time)."""
        with self._paced:
            self._paced.wait_for(self._pace.ready, rule.PACE_WAIT_S)
            self._pace.ticked()

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
                time.sleep(rule.HOLD_PERIOD_S)

    def spin(self):
        if self._wait_for:
            self._hold()
        schedule = rule.TickSchedule(self._speed, self._start, self._tick_hz, time.monotonic(), self._pace.topics)
        rospy.loginfo(schedule.start_line())
        while not rospy.is_shutdown():
            try:
                now = schedule.tick()
            except rule.ClockTooFar:
                exit_on_startup_error(StartupError(rule.too_far_line('~start')), stop_launch=False)
            if self._pace.topics:
                self._wait_for_pace()
            self._pub.publish(Clock(clock=rospy.Time.from_sec(now)))
            delay_s, behind = schedule.delay(time.monotonic())
            if delay_s > 0.0:
                time.sleep(delay_s)   # wall time: this node makes ROS time
            elif behind:
                rospy.logwarn_throttle(10.0, schedule.behind_line())


def main():
    SimClock(**init_node('sim_clock', read_settings)).spin()
