"""The observer of tools/netns_fleet.sh: subscribes to every robot's battery_status (robot0 ...
robot<M-1>) from the observer's network namespace, on ROS 1 (rospy: ROS_MASTER_URI, ROS_IP) or on ROS 2
(rclpy: a super client of the discovery server, ROS_SUPER_CLIENT=TRUE), as ROS_VERSION says.

    netns_fleet_observer.py M        (started by tools/netns_fleet.sh, never by hand)

It reads one command a line on standard input and answers each with one line on standard output:

    seen TIMEOUT START         -> seen N of M robots from the observer host in T s   (T: since START, epoch s)
    rates SECONDS              -> rates MIN .. MAX Hz received, MIN .. MAX Hz stamped, over S s (every robot)
    killed T FIRST COUNT       -> (nothing) robots FIRST .. FIRST+COUNT-1 lost their host at T (epoch s)
    resumed T TIMEOUT          -> resumed K of COUNT robots, worst |after - before| X % (within 1 %: yes|no)
                                  (before: each robot's last level stamped before the kill; after: its first
                                  stamped after T, when its host was started again)
    quit
"""
import os
import sys
import threading
import time

POLL_S = 0.05


class Robots:
    """Every robot's arrivals: (receipt time, stamp, percentage), appended by the subscriptions' threads."""

    def __init__(self, count):
        self.names = ['robot%d' % k for k in range(count)]
        self.lock = threading.Lock()
        self.arrivals = {name: [] for name in self.names}

    def on_status(self, name, stamp_s, percentage):
        with self.lock:
            self.arrivals[name].append((time.time(), stamp_s, percentage))

    def snapshot(self, names=None):
        with self.lock:
            return {name: list(self.arrivals[name]) for name in (names or self.names)}


def subscribe_ros1(robots):
    import rospy
    from sensor_msgs.msg import BatteryState
    rospy.init_node('netns_observer', disable_signals=True)
    for name in robots.names:
        rospy.Subscriber('/%s/battery_status' % name, BatteryState,
                         lambda msg, name=name: robots.on_status(name, msg.header.stamp.to_sec(), msg.percentage),
                         queue_size=10)
    return lambda: None


def subscribe_ros2(robots):
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from sensor_msgs.msg import BatteryState
    from battery_simulator.ros2.qos import STATUS_QOS
    rclpy.init()
    node = rclpy.create_node('netns_observer')
    for name in robots.names:
        node.create_subscription(
            BatteryState, '/%s/battery_status' % name,
            lambda msg, name=name: robots.on_status(
                name, msg.header.stamp.sec + 1e-9 * msg.header.stamp.nanosec, msg.percentage), STATUS_QOS)
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    spinning = threading.Thread(target=executor.spin, daemon=True)
    spinning.start()

    def close():
        executor.shutdown()
        spinning.join(5.0)
        node.destroy_node()
        rclpy.try_shutdown()
    return close


def seen(robots, timeout_s, start):
    deadline = time.monotonic() + timeout_s
    while True:
        arrivals = robots.snapshot()
        firsts = [items[0][0] for items in arrivals.values() if items]
        if len(firsts) == len(robots.names) or time.monotonic() > deadline:
            break
        time.sleep(POLL_S)
    last = max(firsts) if len(firsts) == len(robots.names) else time.time()
    return 'seen %d of %d robots from the observer host in %.1f s' % (len(firsts), len(robots.names), last - start)


def rates(robots, seconds):
    start = time.time()
    time.sleep(seconds)
    end = time.time()
    received, stamped = [], []   # as they arrived here, and as their hosts stamped them (sent)
    for items in robots.snapshot().values():
        window = [(t, stamp) for t, stamp, _ in items if start <= t <= end]
        for rates, times in ((received, [t for t, _ in window]), (stamped, [stamp for _, stamp in window])):
            rates.append((len(times) - 1) / (times[-1] - times[0]) if len(times) > 1 else 0.0)
    return 'rates %.4f .. %.4f Hz received, %.4f .. %.4f Hz stamped, over %.0f s (every robot)' % (
        min(received), max(received), min(stamped), max(stamped), seconds)


def resumed(robots, killed, restarted_s, timeout_s):
    killed_s, first, count = killed
    names = robots.names[first:first + count]
    deadline = time.monotonic() + timeout_s
    while True:
        arrivals = robots.snapshot(names)
        pairs = {}
        for name, items in arrivals.items():
            before = [p for _, stamp, p in items if stamp < killed_s]
            after = [p for _, stamp, p in items if stamp > restarted_s]
            if before and after:
                pairs[name] = (before[-1], after[0])
        if len(pairs) == len(names) or time.monotonic() > deadline:
            break
        time.sleep(POLL_S)
    worst = max(pairs, key=lambda name: abs(pairs[name][1] - pairs[name][0]), default=None)
    change = abs(pairs[worst][1] - pairs[worst][0]) if worst else float('nan')
    return 'resumed %d of %d robots, worst |after - before| %.2f %% (%s: %.2f %% -> %.2f %%) (within 1 %%: %s)' % (
        len(pairs), len(names), 100.0 * change, worst, 100.0 * pairs[worst][0] if worst else float('nan'),
        100.0 * pairs[worst][1] if worst else float('nan'),
        'yes' if len(pairs) == len(names) and change < 0.01 else 'no')


def main():
    robots = Robots(int(sys.argv[1]))
    close = (subscribe_ros2 if os.environ.get('ROS_VERSION') == '2' else subscribe_ros1)(robots)
    killed = None
    for line in sys.stdin:
        words = line.split()
        if not words:
            continue
        if words[0] == 'quit':
            break
        if words[0] == 'seen':
            answer = seen(robots, float(words[1]), float(words[2]))
        elif words[0] == 'rates':
            answer = rates(robots, float(words[1]))
        elif words[0] == 'killed':
            killed = (float(words[1]), int(words[2]), int(words[3]))
            continue
        elif words[0] == 'resumed':
            answer = resumed(robots, killed, float(words[1]), float(words[2]))
        else:
            answer = 'unknown command: %s' % line.strip()
        print(answer, flush=True)
    close()


if __name__ == '__main__':
    main()
