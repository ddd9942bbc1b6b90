#!/usr/bin/python3
"""How long a cmd_vel takes to show on battery_status on ROS 1 (docs/development.md, "the data path of a cmd_vel").

sim.launch's two nodes (battery_sim_server.py and battery_state_pub.py, as separate processes) on a master of
their own; the robot starts driving (1 m/s on cmd_vel, 20 Hz) at a random moment, and the time until the
battery's current shows the drive is measured on the server's state topic (battery_simulator/state: one
model update and one serialization) and on battery_status (the second process: one more hop, and the wait for
its next tick at ~rate). Each trial then stops and waits for the current to settle.

    source build/devel/setup.bash
    /usr/bin/python3 tools/cmd_vel_latency.py [--trials 20] [--rate 1] [--update-rate 10]
    tools/ros2.sh python3 tools/cmd_vel_latency.py --ros2 [...]    # battery_sim on ROS 2, the same measure

The reference in the same run is the bound the two periods give: 1 / update_rate + 1 / rate.
"""
import argparse
import os
import random
import socket
import statistics
import subprocess
import sys
import tempfile
import threading
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DRIVE_W_PER_MPS = 40.0   # the drive's power in the config: 1 m/s adds ~3 A at 12 V
THRESHOLD_A = 1.0        # the current "shows the drive" once it is this much above the idle current


def free_port():
    with socket.socket() as probe:
        probe.bind(('127.0.0.1', 0))
        return probe.getsockname()[1]


def start(command, env):
    return subprocess.Popen(command, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                            start_new_session=True)


def stop(process):
    if process.poll() is None:
        os.killpg(process.pid, 2)
        try:
            process.wait(timeout=15)
        except subprocess.TimeoutExpired:
            os.killpg(process.pid, 9)
            process.wait()


class FirstAbove:
    """The first receipt time (monotonic) after ``armed_at`` of a message whose |current| exceeds a threshold."""

    def __init__(self, current_of):
        self.current_of = current_of
        self.lock = threading.Condition()
        self.threshold = None
        self.armed_at = None
        self.seen_at = None
        self.latest = None

    def on_message(self, msg):
        now = time.monotonic()
        with self.lock:
            self.latest = abs(self.current_of(msg))
            if self.armed_at is not None and self.seen_at is None and self.latest > self.threshold:
                self.seen_at = now
            self.lock.notify_all()

    def arm(self, threshold, at):
        with self.lock:
            self.threshold, self.armed_at, self.seen_at = threshold, at, None

    def wait_seen(self, timeout_s):
        with self.lock:
            self.lock.wait_for(lambda: self.seen_at is not None, timeout_s)
            return self.seen_at


def ros1_graph(args, config, processes):
    """sim.launch's two processes on a master of their own; (publish_drive(), state, status)."""
    port = free_port()
    env = dict(os.environ, ROS_MASTER_URI='http://127.0.0.1:%d' % port, ROS_IP='127.0.0.1')
    os.environ.update(env)
    scripts = os.path.join(ROOT, 'scripts')
    processes.append(start(['rosmaster', '--core', '-p', str(port)], env))
    time.sleep(1.0)
    processes.append(start([os.path.join(scripts, 'battery_sim_server.py'), '__name:=BatterySimServer',
                            '_config:=' + config, '_time_scale:=1', '_update_rate:=%g' % args.update_rate], env))
    processes.append(start([os.path.join(scripts, 'battery_state_pub.py'), '_rate:=%g' % args.rate], env))
    import rospy
    from geometry_msgs.msg import Twist, Vector3
    from sensor_msgs.msg import BatteryState
    from battery_simulator.msg import BatterySimState
    rospy.init_node('cmd_vel_latency', disable_signals=True)
    state = FirstAbove(lambda msg: msg.battery.current)
    status = FirstAbove(lambda msg: msg.current)
    rospy.Subscriber('battery_simulator/state', BatterySimState, state.on_message, queue_size=10, tcp_nodelay=True)
    rospy.Subscriber('battery_status', BatteryState, status.on_message, queue_size=10, tcp_nodelay=True)
    cmd_vel = rospy.Publisher('cmd_vel', Twist, queue_size=10)
    connected = lambda: cmd_vel.get_num_connections() > 0   # noqa: E731
    return (lambda: cmd_vel.publish(Twist(linear=Vector3(x=1.0)))), state, status, connected, \
        lambda: rospy.signal_shutdown('done')


def ros2_graph(args, config, processes):
    """battery_sim (its two nodes in one process, one executor thread), under tools/ros2.sh."""
    os.environ['ROS_DOMAIN_ID'] = str(150 + os.getpid() % 80)   # a domain of this run's own (tools/ros2.sh: local DDS)
    processes.append(start(['battery_sim', '--ros-args', '-r', '__ns:=/latency', '-p', 'config:=' + config,
                            '-p', 'time_scale:=1.0', '-p', 'update_rate:=%g' % args.update_rate,
                            '-p', 'rate:=%g' % args.rate], dict(os.environ)))
    import rclpy
    from geometry_msgs.msg import Twist, Vector3
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
    from sensor_msgs.msg import BatteryState
    from battery_simulator.msg import BatterySimState
    rclpy.init()
    node = rclpy.create_node('cmd_vel_latency', namespace='/latency')
    state = FirstAbove(lambda msg: msg.battery.current)
    status = FirstAbove(lambda msg: msg.current)
    latched = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)
    node.create_subscription(BatterySimState, 'battery_simulator/state', state.on_message, latched)
    node.create_subscription(BatteryState, 'battery_status', status.on_message, 10)
    cmd_vel = node.create_publisher(Twist, 'cmd_vel', 10)
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    threading.Thread(target=executor.spin, daemon=True).start()
    connected = lambda: cmd_vel.get_subscription_count() > 0   # noqa: E731

    def close():
        executor.shutdown()
        node.destroy_node()
        rclpy.try_shutdown()
    return (lambda: cmd_vel.publish(Twist(linear=Vector3(x=1.0)))), state, status, connected, close


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--trials', type=int, default=20)
    parser.add_argument('--rate', type=float, default=1.0, help="battery_state_pub's rate, Hz")
    parser.add_argument('--update-rate', type=float, default=10.0, help="the server's update_rate, Hz")
    parser.add_argument('--ros2', action='store_true', help='battery_sim on ROS 2 (run under tools/ros2.sh)')
    args = parser.parse_args()
    config = tempfile.NamedTemporaryFile('w', suffix='.yaml', delete=False)
    config.write('preset: lg_hg2_3s1p\ndrive_power_w_per_mps: %g\n' % DRIVE_W_PER_MPS)
    config.close()
    processes = []
    close = None
    try:
        publish_drive, state, status, connected, close = (ros2_graph if args.ros2 else ros1_graph)(
            args, config.name, processes)
        measure(args, publish_drive, state, status, connected)
    finally:
        if close is not None:
            close()
        for process in reversed(processes):
            stop(process)
        os.unlink(config.name)


def measure(args, publish_drive, state, status, connected):
    deadline = time.monotonic() + 60.0
    while (status.latest is None or state.latest is None or not connected()) and time.monotonic() < deadline:
        time.sleep(0.05)
    if status.latest is None or state.latest is None:
        sys.exit('the nodes did not start within 60 s')
    time.sleep(1.5)
    idle_a = status.latest
    to_state, to_status = [], []
    for trial in range(args.trials):
        time.sleep(random.uniform(0.0, 1.0 / args.rate))   # a random phase against both periods
        driving = threading.Event()
        driving.set()

        def drive():
            while driving.is_set():
                publish_drive()
                time.sleep(0.05)
        started = time.monotonic()
        state.arm(idle_a + THRESHOLD_A, started)
        status.arm(idle_a + THRESHOLD_A, started)
        thread = threading.Thread(target=drive, daemon=True)
        thread.start()
        seen_state = state.wait_seen(10.0)
        seen_status = status.wait_seen(10.0)
        driving.clear()
        thread.join()
        if seen_state is None or seen_status is None:
            print('trial %d: not seen within 10 s' % trial)
            continue
        to_state.append(seen_state - started)
        to_status.append(seen_status - started)
        settle = time.monotonic() + 10.0
        while time.monotonic() < settle and (status.latest > idle_a + 0.2 or state.latest > idle_a + 0.2):
            time.sleep(0.05)
        time.sleep(0.3)

    def row(name, values):
        if not values:
            return '%-48s no trial' % name
        return '%-48s %6.3f %6.3f %6.3f %6.3f' % (name, min(values), statistics.median(values),
                                                  statistics.mean(values), max(values))
    print('%s: cmd_vel -> reflected, s (%d trials; update_rate %g Hz, battery_status rate %g Hz)' % (
        'ROS 2' if args.ros2 else 'ROS 1', len(to_status), args.update_rate, args.rate))
    print('%-48s %6s %6s %6s %6s' % ('', 'min', 'median', 'mean', 'max'))
    print(row('battery_simulator/state (the server)', to_state))
    print(row('battery_status', to_status))
    print(row('battery_status - state', [b - a for a, b in zip(to_state, to_status)]))
    print('reference (same run): the periods bound it at 1/update_rate + 1/rate = %.3f s'
          % (1.0 / args.update_rate + 1.0 / args.rate))


if __name__ == '__main__':
    main()
