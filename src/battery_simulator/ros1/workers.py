"""The threads a battery process runs, shared by all the batteries it hosts.

One battery (battery_sim_server.py, battery_state_pub.py) or a thousand
(battery_fleet.py): the same few threads, never one per battery.

  - UpdateLoop: steps every BatterySimServer at ``update_rate`` (wall time), and
    one at once when it is woken (a goal, a service, a contact change);
  - StatusTimer: publishes every action server's goal status at 5 Hz, in place
    of actionlib's timer per server (which also dies on a /clock jump back);
  - ChangeLoop: sends a publisher's changes on battery_status at once, a burst
    as at most one message per URGENT_GAP_S (its last state);
  - DiagnosticsLoop: every publisher's "Battery" status in one DiagnosticArray.
"""
import threading
import time

import rospy
from diagnostic_msgs.msg import DiagnosticArray

from battery_simulator.core import ros_names
from battery_simulator.core.diagnostics import DIAGNOSTIC_PERIOD_S
from battery_simulator.core.status_rules import URGENT_GAP_S
from battery_simulator.ros1.startup import ending_the_node_on_error

STATUS_PERIOD_S = 0.2        # actionlib's default status_frequency, 5 Hz


class UpdateLoop:
    """One worker thread that steps many servers: all every period, a woken one at once.

    Lock order: a server's own lock may be held while waking the loop (self._wake
    is taken last and briefly); the loop never holds self._wake while it steps.
    """

    def __init__(self, update_rate, after_round=None):
        """``after_round()`` runs after each round of updates (a fleet host writes its saved states)."""
        self._period_s = 1.0 / update_rate
        self._after_round = after_round
        self._servers = []
        self._wake = threading.Condition()
        self._woken = {}                  # servers to update at once (an ordered set)
        self._stopping = threading.Event()
        # daemon: a node stopped during start-up must not hang on it; stop() joins it otherwise
        self._thread = threading.Thread(target=self._run, name='battery_models', daemon=True)

    def add(self, server):
        self._servers.append(server)

    def wake(self, server):
        with self._wake:
            self._woken[server] = None
            self._wake.notify()

    def start(self):
        self._thread.start()

    def stop(self):
        """Stop stepping; each server then preempts its goal and saves its state (idempotent)."""
        self._stopping.set()
        with self._wake:
            self._wake.notify()
        if self._thread.is_alive() and threading.current_thread() is not self._thread:
            self._thread.join(timeout=2.0 + 0.002 * len(self._servers))

    def _run(self):
        with ending_the_node_on_error('the battery model worker'):
            self._run_updates()
            for server in self._servers:
                server.finish()

    def _run_updates(self):
        next_update = time.monotonic()
        while not self._stopping.is_set():
            with self._wake:
                self._wake.wait_for(lambda: self._woken or self._stopping.is_set(),
                                    max(0.0, next_update - time.monotonic()))
                woken, self._woken = list(self._woken), {}
            if self._stopping.is_set():
                return
            due = time.monotonic() >= next_update
            for server in self._servers if due else woken:
                if not server.run_once():
                    return   # rospy is shutting down
            if due:
                next_update = max(next_update + self._period_s, time.monotonic())
                if self._after_round is not None:
                    self._after_round()


class StatusTimer:
    """Publishes the goal status of every action server from one rospy timer (reset: survives clock jumps).

    An action server's status goes out only while someone listens (a client
    always does); with nobody listening there is nothing to keep up to date.
    """

    def __init__(self):
        self._servers = []
        self._lock = threading.Lock()
        self._timer = None

    def add(self, simple_action_server):
        """Take over the status of a started actionlib SimpleActionServer."""
        server = simple_action_server.action_server
        own_timer = getattr(server, 'status_timer', None)
        if own_timer is not None:
            own_timer.shutdown()
        server.status_timer = _Membership(self, server)
        with self._lock:
            self._servers.append(server)
        if self._timer is None:
            self._timer = rospy.Timer(rospy.Duration(STATUS_PERIOD_S), self._publish, reset=True)

    def remove(self, server):
        with self._lock:
            if server in self._servers:
                self._servers.remove(server)

    def _publish(self, event):
        with self._lock:
            servers = list(self._servers)
        for server in servers:
            if server.status_pub.get_num_connections() > 0:
                server.publish_status_async(event)


class _Membership:
    """Stands in for an action server's own status timer: ActionServer.stop() shuts it down."""

    def __init__(self, timer, server):
        self._timer, self._server = timer, server

    def shutdown(self):
        self._timer.remove(self._server)


class ChangeLoop:
    """Sends changes on battery_status at once, at most one message per URGENT_GAP_S per battery."""

    def __init__(self):
        self._cond = threading.Condition()
        self._pending = {}        # publisher -> the newest publish_now update to acknowledge (0: none)
        self._sent_at = {}        # publisher -> monotonic time of its last immediate message
        self._thread = threading.Thread(target=self._run, name='battery_changes', daemon=True)

    def start(self):
        self._thread.start()

    def request(self, publisher, update=0):
        """``publisher`` has a change to send at once; ``update``: a service's update to acknowledge after it."""
        with self._cond:
            self._pending[publisher] = max(self._pending.get(publisher, 0), update)
            self._cond.notify()

    def _run(self):
        with ending_the_node_on_error('the change publisher thread'):
            while not rospy.is_shutdown():
                ready = self._wait_for_ready()
                for publisher, ack in ready:
                    publisher.publish_once()
                    if ack:
                        publisher.acknowledge(ack)   # the server's service may reply now

    def _wait_for_ready(self):
        """The pending publishers whose gap has passed, with their acks; waits (bounded) for one."""
        with self._cond:
            if not self._cond.wait_for(lambda: self._pending, DIAGNOSTIC_PERIOD_S):
                return []
            now = time.monotonic()
            ready = [p for p in self._pending if self._sent_at.get(p, -URGENT_GAP_S) + URGENT_GAP_S <= now]
            if not ready:
                earliest = min(self._sent_at[p] for p in self._pending) + URGENT_GAP_S
                self._cond.wait(max(0.0, earliest - now))   # wall time: the gap bounds a message rate
                return []
            for publisher in ready:
                self._sent_at[publisher] = now
            return [(publisher, self._pending.pop(publisher)) for publisher in ready]


class DiagnosticsLoop:
    """Every publisher's diagnostic status in one DiagnosticArray on /diagnostics, every DIAGNOSTIC_PERIOD_S."""

    def __init__(self, publishers):
        self._publishers = publishers
        self._pub = rospy.Publisher(ros_names.DIAGNOSTICS, DiagnosticArray, queue_size=10)
        self._thread = threading.Thread(target=self._run, name='diagnostics', daemon=True)

    def start(self):
        self._thread.start()

    def _run(self):
        with ending_the_node_on_error('the diagnostics thread'):
            while not rospy.is_shutdown():
                if self._pub.get_num_connections() > 0:
                    array = DiagnosticArray(status=[p.diagnostic_status() for p in self._publishers])
                    array.header.stamp = rospy.Time.now()
                    self._pub.publish(array)
                time.sleep(DIAGNOSTIC_PERIOD_S)
