"""``sim_clock`` (ROS 2): ``/clock`` running ``speed`` times as fast as wall time, as ROS 1's sim_clock.py.

It ticks ``tick_hz`` times a second of wall time (default 1000), each tick advancing ROS time by
``speed / tick_hz``, counted in ticks from ``start`` (robot/clock.py's policy: it never drifts; when the
machine cannot keep up the clock runs slower than asked and says so). With ``wait_for`` (a list of topic
names) it holds ROS time at ``start`` until each has a publisher (at most ``wait_timeout`` wall s). Every
node started with ``use_sim_time:=true`` follows it.

:Parameters: ``speed`` (0 < s <= 10000, default 1), ``start`` (s, 0), ``tick_hz`` (0 < f <= 10000, 1000),
  ``wait_for`` (topic names, none), ``wait_timeout`` (s, 60), ``pace_on`` (topic names, none: each tick waits, at
  most 0.5 wall s, for a message on each since the last; robot/clock.py's Pace)
:Publishes: ``/clock`` (rosgraph_msgs/msg/Clock)
"""
import os
import sys
import threading
import time

from rosgraph_msgs.msg import Clock
from rclpy.time import Time

from battery_simulator.core import ros_names
from battery_simulator.robot import clock as rule
from battery_simulator.core.node_settings import EXIT_STARTUP_ERROR
from battery_simulator.ros2.startup import run_node, steady_clock


FINISH_JOIN_S = 1.0   # the longest a stop waits for the clock's thread to end


def clock_msg(seconds):
    return Clock(clock=Time(nanoseconds=int(round(seconds * 1e9))).to_msg())


class SimClock:
    """Publishes /clock from a thread of its own (wall time: this node makes ROS time); the node's executor
    serves its parameters. ``start_now`` False: the caller calls ``start()`` (battery_demo, once every node
    of its process is up)."""

    def __init__(self, node, speed, start, tick_hz, wait_for=(), wait_timeout=60.0, start_now=True, pace_on=()):
        self._node = node
        self._speed, self._start, self._tick_hz = speed, start, tick_hz
        self._wait_for = [node.resolve_topic_name(topic) for topic in wait_for]
        self._wait_timeout = wait_timeout
        self._pub = node.create_publisher(Clock, ros_names.CLOCK, 10)
        self._pace = rule.Pace(node.resolve_topic_name(topic) for topic in pace_on)
        self._paced = threading.Condition()
        self._pace_subs = {}   # topic -> subscription, once its type is known (from its publishers)
        # made on the executor's thread (made on the clock's, the process aborted at its end)
        self._pace_timer = node.create_timer(rule.HOLD_PERIOD_S, self._follow_pace, clock=steady_clock()) \
            if self._pace.topics else None
        self._stopped = threading.Event()
        self._thread = threading.Thread(target=self._run, name='sim_clock', daemon=True)
        if start_now:
            self.start()

    def start(self):
        self._thread.start()

    def stop(self):
        self._stopped.set()

    def finish(self):
        """At a stop signal: no tick after it, and the thread ended (a pace wait cut short) before rclpy goes
        (a thread still in rclpy at the end aborted the process: "terminate called without an active exception")."""
        self.stop()
        with self._paced:
            self._paced.notify_all()
        if self._thread.is_alive():
            self._thread.join(FINISH_JOIN_S)
        return lambda: True

    def _hold(self):
        """Publish ``start`` until every ``wait_for`` topic has a publisher (bounded, wall time)."""
        log = self._node.get_logger()
        deadline = time.monotonic() + self._wait_timeout
        missing = self._wait_for
        log.info('sim_clock: holding ROS time at %g s until %s are published' % (self._start, ', '.join(missing)))
        while missing and not self._stopped.is_set():
            self._pub.publish(clock_msg(self._start))
            missing = [topic for topic in missing if self._node.count_publishers(topic) == 0]
            if missing and time.monotonic() > deadline:
                log.warning('sim_clock: no publisher of %s after %g s: starting the clock anyway'
                         % (', '.join(missing), self._wait_timeout))
                return
            if missing:
                self._stopped.wait(rule.HOLD_PERIOD_S)

    def _follow_pace(self):
        """Subscribe to the pace_on topics whose type the graph shows now (rclpy takes no message of any type)."""
        import importlib
        if len(self._pace_subs) == len(self._pace.topics):
            self._node.destroy_timer(self._pace_timer)
            return
        types = dict(self._node.get_topic_names_and_types())
        for topic in self._pace.topics:
            if topic in self._pace_subs or not types.get(topic):
                continue
            package, _, name = types[topic][0].split('/')
            msg_type = getattr(importlib.import_module(package + '.msg'), name)
            self._pace_subs[topic] = self._node.create_subscription(
                msg_type, topic, lambda _msg, topic=topic: self._on_pace(topic), 10)

    def _on_pace(self, topic):
        with self._paced:
            self._pace.heard(topic)
            self._paced.notify_all()

    def _wait_for_pace(self):
        """Until every pace_on topic sent a message since the last tick (bounded, wall time); a topic not
        subscribed yet (no publisher seen) is not waited for."""
        with self._paced:
            for topic in self._pace.topics:
                if topic not in self._pace_subs:
                    self._pace.heard(topic)
            self._paced.wait_for(lambda: self._pace.ready() or self._stopped.is_set(), rule.PACE_WAIT_S)
            self._pace.ticked()

    def _run(self):
        try:
            self._tick()
        except Exception as error:   # a context shut down under the thread: the process is ending
            if not self._stopped.is_set() and self._node.context.ok():
                raise error

    def _tick(self):
        if self._wait_for:
            self._hold()
        log = self._node.get_logger()
        schedule = rule.TickSchedule(self._speed, self._start, self._tick_hz, time.monotonic(), self._pace.topics)
        log.info(schedule.start_line())
        while not self._stopped.is_set() and self._node.context.ok():
            try:
                now = schedule.tick()
            except rule.ClockTooFar:
                log.fatal(rule.too_far_line('start'))
                sys.stderr.flush()
                os._exit(EXIT_STARTUP_ERROR)
            if self._pace.topics:
                self._wait_for_pace()
            self._pub.publish(clock_msg(now))
            delay_s, behind = schedule.delay(time.monotonic())
            if delay_s > 0.0:
                time.sleep(delay_s)
            elif behind:
                log.warning(schedule.behind_line(), throttle_duration_sec=10.0)


def main(args=None):
    run_node('sim_clock', rule.SETTINGS, SimClock, args)
