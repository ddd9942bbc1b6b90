"""Shared by the rostest nodes: bounded waits and a BatteryState recorder."""
import os
import random
import signal
import subprocess
import sys
import threading
import time

import rospkg
import rospy
from sensor_msgs.msg import BatteryState
from std_msgs.msg import Bool


def result_name(default):
    """The name this test node runs under (rostest passes __name:=<test-name>), so that the same
    test script run against two launches (X.test and X_fleet.test) writes two result files."""
    for argument in sys.argv:
        if argument.startswith('__name:='):
            return argument.split(':=', 1)[1]
    return default


def node_command(script):
    """The command that runs one of the package's scripts directly: what rosrun runs, without
    rosrun's package search (about a second each, which adds up over many runs)."""
    return [os.path.join(rospkg.RosPack().get_path('battery_simulator'), 'scripts', script)]


def stop_process(process, first_signal=signal.SIGINT, timeout_s=20.0):
    """End a child started with start_new_session=True, by its pid: ``first_signal``, then SIGKILL."""
    if process.poll() is None:
        os.killpg(process.pid, first_signal)
        try:
            process.wait(timeout=timeout_s)
        except subprocess.TimeoutExpired:
            os.killpg(process.pid, signal.SIGKILL)
            process.wait()


def wait_for(condition, timeout_s, what):
    """Poll ``condition`` until it is true; AssertionError naming ``what`` after ``timeout_s``."""
    deadline = time.monotonic() + timeout_s
    while not condition():
        if time.monotonic() > deadline:
            raise AssertionError('timed out after %g s waiting for %s' % (timeout_s, what))
        if rospy.is_shutdown():
            raise AssertionError('ROS shut down while waiting for %s' % what)
        time.sleep(0.02)


class Recorder:
    """Keeps every message of a topic with its arrival time (monotonic)."""

    def __init__(self, topic, msg_type=BatteryState):
        self._lock = threading.Lock()
        self._messages = []
        self._sub = rospy.Subscriber(topic, msg_type, self._on_message, queue_size=100)

    def _on_message(self, msg):
        with self._lock:
            self._messages.append((time.monotonic(), msg))

    def count(self):
        with self._lock:
            return len(self._messages)

    def arrival(self, index):
        """The monotonic arrival time of the ``index``-th message."""
        with self._lock:
            return self._messages[index][0]

    def since(self, index):
        with self._lock:
            return [m for _, m in self._messages[index:]]

    def latest(self):
        with self._lock:
            return self._messages[-1][1] if self._messages else None

    def next_after(self, index, timeout_s=10.0):
        """The first message after the ``index``-th."""
        wait_for(lambda: self.count() > index, timeout_s, 'a message on %s' % self._sub.name)
        return self.since(index)[0]

    def wait_new(self, index, predicate, timeout_s, what):
        """The first message after the ``index``-th for which ``predicate`` holds."""
        found = []

        def check():
            found.extend(m for m in self.since(index) if predicate(m))
            return bool(found)
        wait_for(check, timeout_s, what)
        return found[0]

    def wait_until(self, predicate, timeout_s, what):
        """The first new message for which ``predicate`` holds."""
        found = []

        def check():
            latest = self.latest()
            if latest is not None and predicate(latest):
                found.append(latest)
                return True
            return False
        wait_for(check, timeout_s, what)
        return found[0]


class SetStateProxy:
    """battery_simulator/set_state called as Part 2 wrote it, set_state(percentage, temperature_c,
    state_of_health); Part 5's gauge_error (NaN: none) is a keyword."""

    def __init__(self, name):
        from battery_simulator.srv import SetState
        self._proxy = rospy.ServiceProxy(name, SetState)

    def __call__(self, percentage=float('nan'), temperature_c=float('nan'), state_of_health=float('nan'),
                 gauge_error=float('nan')):
        return self._proxy(percentage=percentage, temperature_c=temperature_c, state_of_health=state_of_health,
                           gauge_error=gauge_error)

    def wait_for_service(self, timeout=None):
        return self._proxy.wait_for_service(timeout)


def contact_delays(status, contact, toggles, timeout_s, robot=''):
    """charger_contact (the publisher ``contact``) -> the status it asks for on battery_status (the Recorder
    ``status``), wall s, ``toggles`` times, each waited for at most ``timeout_s``."""
    delays = []
    for index in range(toggles):
        connected = index % 2 == 0
        wanted = (BatteryState.POWER_SUPPLY_STATUS_CHARGING if connected
                  else BatteryState.POWER_SUPPLY_STATUS_DISCHARGING)
        start, sent = status.count(), time.monotonic()
        contact.publish(Bool(data=connected))
        found = status.wait_new(start, lambda m: m.power_supply_status == wanted, timeout_s,
                                (robot + ' status %d' % wanted).strip())
        index = next(k for k, m in enumerate(status.since(start)) if m is found)
        delays.append(status.arrival(start + index) - sent)
        time.sleep(0.1 + 0.2 * random.random())   # different points of the update and publish periods
    return delays
