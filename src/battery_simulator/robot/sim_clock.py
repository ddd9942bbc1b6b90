"""A simulation clock (sim_clock): /clock running ``~speed`` times as fast as wall time.

It ticks ``~tick_hz`` times a second of wall time (default 1000, as Gazebo
does), each tick advancing ROS time by ``~speed / ~tick_hz`` (0.24 s at speed
240), so that every node under ``/use_sim_time`` (the battery, the robot, your
own) runs faster together: a sped-up demo spends on each trip the energy the
trip takes. ROS time is counted in ticks from ``~start``, so it never drifts
against itself; when the machine cannot keep up, the clock runs slower than
asked (as Gazebo's real-time factor drops) and says so.

:ROS Parameters:
  - ``~speed`` (float > 0, at most 10000): ROS seconds per wall second (default 1)
  - ``~start`` (float >= 0, s): ROS time at the first tick (default 0)
  - ``~tick_hz`` (float, Hz, 0 < f <= 10000): ticks per wall second (default 1000)

:Publishes:
  - ``/clock`` (rosgraph_msgs/Clock)
"""
import time

import rospy
from rosgraph_msgs.msg import Clock

from battery_simulator.ros.startup import checked_param, init_node, is_number

BEHIND_S = 0.1   # further behind its wall schedule than this, the clock gives up catching up


def read_settings():
    return dict(
        speed=checked_param('~speed', 1.0, lambda v: is_number(v) and 0 < v <= 10000, 'a number in (0, 10000]'),
        start=checked_param('~start', 0.0, lambda v: is_number(v) and v >= 0, 'a number >= 0 s'),
        tick_hz=checked_param('~tick_hz', 1000.0, lambda v: is_number(v) and 0 < v <= 10000,
                              'a number in (0, 10000] Hz'),
    )


def tick_time(start, speed, tick_hz, ticks):
    """ROS time (s) after ``ticks`` ticks: counted, not summed, so it never drifts."""
    return start + ticks * speed / tick_hz


class SimClock:
    def __init__(self, speed, start, tick_hz):
        self._speed, self._start, self._tick_hz = speed, start, tick_hz
        self._pub = rospy.Publisher('/clock', Clock, queue_size=10)

    def spin(self):
        rospy.loginfo('sim_clock: ROS time x%g from %g s, %g ticks a second of %g ms', self._speed, self._start,
                      self._tick_hz, 1000.0 * self._speed / self._tick_hz)
        period_s = 1.0 / self._tick_hz
        ticks, next_tick = 0, time.monotonic()
        while not rospy.is_shutdown():
            ticks += 1
            self._pub.publish(Clock(clock=rospy.Time.from_sec(tick_time(self._start, self._speed, self._tick_hz,
                                                                         ticks))))
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
