"""What the ROS 2 node tests share: start a node process (ended by pid), and a probe node in the
test process that waits for messages, calls services, sets parameters and sends goals, each with
a bound. Run under tools/ros2.sh (its environment keeps DDS on 127.0.0.1)."""
import math
import os
import signal
import subprocess
import tempfile
import threading
import time

import rclpy
from rclpy.action import ActionClient
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from rcl_interfaces.srv import SetParameters
from sensor_msgs.msg import BatteryState

from battery_simulator.srv import SetState

RELIABLE = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)
LATCHED = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)
NAN = math.nan
CHARGING, DISCHARGING, NOT_CHARGING, FULL = (BatteryState.POWER_SUPPLY_STATUS_CHARGING,
                                             BatteryState.POWER_SUPPLY_STATUS_DISCHARGING,
                                             BatteryState.POWER_SUPPLY_STATUS_NOT_CHARGING,
                                             BatteryState.POWER_SUPPLY_STATUS_FULL)


class NodeProcess:
    """An executable of the package, started with ``--ros-args`` and ended by pid (SIGINT, then SIGKILL)."""

    def __init__(self, executable, *ros_args, args=()):
        self.log = tempfile.NamedTemporaryFile(prefix='%s_' % executable, suffix='.log', delete=False)
        command = [executable, *args] + (['--ros-args', *ros_args] if ros_args else [])
        self.process = subprocess.Popen(command, stdout=self.log, stderr=subprocess.STDOUT)
        self.pid = self.process.pid

    def output(self):
        with open(self.log.name, encoding='utf-8', errors='replace') as stream:
            return stream.read()

    def wait_for_output(self, text, timeout_s):
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            if text in self.output():
                return True
            if self.process.poll() is not None:
                return text in self.output()
            time.sleep(0.05)
        return False

    def wait(self, timeout_s):
        """The exit status within ``timeout_s``, or None."""
        try:
            return self.process.wait(timeout_s)
        except subprocess.TimeoutExpired:
            return None

    def stop(self, sig=signal.SIGINT, timeout_s=5.0):
        """End it by pid: ``sig``, then SIGKILL after ``timeout_s``; its exit status."""
        if self.process.poll() is None:
            os.kill(self.pid, sig)
            if self.wait(timeout_s) is None:
                os.kill(self.pid, signal.SIGKILL)
                self.process.wait(5.0)
        return self.process.returncode


class Probe:
    """A node in the test process, spun in a thread of its own."""

    def __init__(self, name='battery_test_probe'):
        if not rclpy.ok():
            rclpy.init()
        self.node = Node(name)
        self._executor = SingleThreadedExecutor()
        self._executor.add_node(self.node)
        self._lock = threading.Lock()
        self._subscriptions = {}
        self._client_nodes = []   # action_client's
        self._thread = threading.Thread(target=self._executor.spin, daemon=True)
        self._thread.start()

    def close(self):
        self._executor.shutdown()
        for node in self._client_nodes:
            node.destroy_node()
        self.node.destroy_node()

    def follow(self, topic, msg_type, qos=RELIABLE):
        """Record every message of ``topic`` from now on; returns the list (appended to as they come)."""
        key = (topic, msg_type, id(qos))
        with self._lock:
            if key not in self._subscriptions:
                received = []
                self._subscriptions[key] = (received, self.node.create_subscription(
                    msg_type, topic, lambda msg: received.append((time.monotonic(), msg)), qos))
            return self._subscriptions[key][0]

    def wait_for(self, topic, msg_type, predicate=lambda msg: True, timeout_s=10.0, qos=RELIABLE, since=None):
        """The first message (received after ``since``, monotonic) that satisfies ``predicate``, or None."""
        received = self.follow(topic, msg_type, qos)
        deadline = time.monotonic() + timeout_s
        index = 0
        while True:
            while index < len(received):
                at, msg = received[index]
                index += 1
                if (since is None or at >= since) and predicate(msg):
                    return msg
            if time.monotonic() >= deadline:
                return None
            time.sleep(0.02)

    def call(self, srv_type, name, request, timeout_s=10.0):
        client = self.node.create_client(srv_type, name)
        try:
            if not client.wait_for_service(timeout_sec=timeout_s):
                raise AssertionError('service %s not available within %g s' % (name, timeout_s))
            future = client.call_async(request)
            return self._result(future, timeout_s, 'service %s' % name)
        finally:
            self.node.destroy_client(client)

    def set_parameter(self, node_name, name, value, timeout_s=10.0):
        """SetParametersResult of setting ``name`` of ``node_name`` to ``value``."""
        request = SetParameters.Request(parameters=[Parameter(name, value=value).to_parameter_msg()])
        return self.call(SetParameters, node_name + '/set_parameters', request, timeout_s).results[0]

    def action_client(self, action_type, name):
        """An action client on a node of its own, handed to the spinning executor once made: rclpy's
        ActionClient adds itself to its node before it has its lock, and the spinner thread, reaching it in
        between, died with "'ActionClient' object has no attribute '_lock'" (two CPU hogs: every later call of
        the probe unanswered)."""
        node = Node('%s_action_client_%d' % (self.node.get_name(), len(self._client_nodes)))
        client = ActionClient(node, action_type, name)
        self._client_nodes.append(node)
        self._executor.add_node(node)
        return client

    def send_goal(self, client, goal, timeout_s=10.0, feedback=None):
        if not client.wait_for_server(timeout_sec=timeout_s):
            raise AssertionError('action server not available within %g s' % timeout_s)
        handle = self._result(client.send_goal_async(goal, feedback_callback=feedback), timeout_s, 'goal')
        assert handle.accepted, 'goal rejected'
        return handle

    def result(self, handle, timeout_s):
        return self._result(handle.get_result_async(), timeout_s, 'result')

    def cancel(self, handle, timeout_s=10.0):
        return self._result(handle.cancel_goal_async(), timeout_s, 'cancel')

    @staticmethod
    def _result(future, timeout_s, what):
        deadline = time.monotonic() + timeout_s
        while not future.done():
            if time.monotonic() >= deadline:
                raise AssertionError('%s: no answer within %g s' % (what, timeout_s))
            time.sleep(0.01)
        return future.result()


def udp_sockets(pids):
    """[(pid, local address)] of every UDP socket the processes ``pids`` hold (ss -uanp)."""
    lines = subprocess.run(['ss', '-uanpH'], capture_output=True, text=True, check=True).stdout.splitlines()
    found = []
    for line in lines:
        for pid in pids:
            if 'pid=%d,' % pid in line:
                found.append((pid, line.split()[3]))
    return found


def set_state(probe, ns, percentage=NAN, temperature_c=NAN, state_of_health=NAN):
    return probe.call(SetState, ns + '/battery_simulator/set_state', SetState.Request(
        percentage=float(percentage), temperature_c=float(temperature_c), state_of_health=float(state_of_health)))


def status_after(probe, ns, predicate, timeout_s=5.0, since=None):
    """The first battery_status of ``ns`` after ``since`` (default now) that satisfies ``predicate``, or None."""
    return probe.wait_for(ns + '/battery_status', BatteryState, predicate, timeout_s,
                          since=time.monotonic() if since is None else since)
