"""The observer of tools/netns_fleet.sh: subscribes to every robot's battery_status (robot0 ...
robot<M-1>) from the observer's network namespace, on ROS 1 (rospy: ROS_MASTER_URI, ROS_IP) or on ROS 2
(rclpy: a super client of the discovery server, ROS_SUPER_CLIENT=TRUE), as ROS_VERSION says.

    netns_fleet_observer.py M        (started by tools/netns_fleet.sh, never by hand)

It reads one command a line on standard input and answers each with one line on standard output:

    seen TIMEOUT START         -> seen N of M robots from the observer host in T s   (T: since START, epoch s)
    rates SECONDS              -> rates MIN .. MAX Hz received, MIN .. MAX Hz stamped, over S s (every robot)
    killed T FIRST COUNT       -> (nothing) robots FIRST .. FIRST+COUNT-1 lost their host at T (epoch s)
    resumed T TIMEOUT LOG SKIP -> resumed K of COUNT robots (and P publish again), worst |resumed - at the
                                  kill| X % (...), first message after: Y % (...) (within 1 %: yes|no)
                                  (resumed: the level the host's LOG, past SKIP lines, says each robot resumed at;
                                  at the kill: its last level stamped before the kill, run on at its rate to the
                                  kill; first after: stamped after T, the restart, beside the last seen)
    quit
"""
import os
import re
import sys
import threading
import time

POLL_S = 0.05
#: no message stamped before the kill arrived for this long: the dead host's connections are read to their end
BEFORE_SETTLED_S = 2.0
#: a robot's level at the kill: its last one seen, run on at the rate of this long before it, s
RATE_WINDOW_S = 20.0


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


#: a host's line for each robot it resumed (ROS 1: "robot7: battery_simulator resumed from ...: 41.2 %, ...";
#: ROS 2: "[robot7.battery_simulator]: battery_simulator resumed from ...: 41.2 %, ...")
RESUMED_LINE = re.compile(r'(robot\d+)(?::|\.battery_simulator\]:) battery_simulator resumed from .*?: ([0-9.]+) %')


def resumed_levels(log_path, skip):
    """{robot: the level (0..1) its host says it resumed at}, from the host's log past its first ``skip``
    lines (those of the run before the kill)."""
    with open(log_path, encoding='utf-8', errors='replace') as stream:
        lines = stream.readlines()[skip:]
    return {m.group(1): float(m.group(2)) / 100.0 for m in map(RESUMED_LINE.search, lines) if m}


def worst_change(pairs):
    """'X % (robotN: a % -> b %)' of the pair (before, after) that differs most."""
    if not pairs:
        return float('nan'), 'none'
    name = max(pairs, key=lambda n: abs(pairs[n][1] - pairs[n][0]))
    before, after = pairs[name]
    return abs(after - before), '%.2f %% (%s: %.2f %% -> %.2f %%)' % (
        100.0 * abs(after - before), name, 100.0 * before, 100.0 * after)


def level_at(seen, at_s):
    """The level a robot had at ``at_s`` (epoch s): its last one seen (``seen``: (stamp, level) in order), run on
    at the rate of its last RATE_WINDOW_S to ``at_s``. On a loaded machine the last message a host got out before
    a SIGKILL may be 25 s older than the kill, which at time x5 is a point of charge."""
    last_s, last = seen[-1]
    window = [(stamp, level) for stamp, level in seen if stamp >= last_s - RATE_WINDOW_S]
    first_s, first = window[0]
    rate = (last - first) / (last_s - first_s) if last_s - first_s >= 0.5 * RATE_WINDOW_S else 0.0
    return last + rate * (at_s - last_s)


def resumed(robots, killed, restarted_s, timeout_s, log_path, skip):
    """Each robot of the killed host: the level it resumed at (its host's log) against its level at the kill
    (level_at; within 1 %: the resume), and its first battery_status after the restart (that it
    publishes again; its level also holds the battery's run between the resume and that message, which a
    slow start on a loaded machine lengthens)."""
    killed_s, first, count = killed
    names = robots.names[first:first + count]
    deadline = time.monotonic() + timeout_s
    settled_since, last_count = None, None
    while True:
        arrivals = robots.snapshot(names)
        levels = resumed_levels(log_path, skip)
        at_resume, first_after = {}, {}
        before_count = 0
        for name, items in arrivals.items():
            before = [(stamp, p) for _, stamp, p in items if stamp < killed_s]
            after = [p for _, stamp, p in items if stamp > restarted_s]
            before_count += len(before)
            if before and after:
                first_after[name] = (before[-1][1], after[0])
            if before and name in levels:
                at_resume[name] = (level_at(before, killed_s), levels[name])
        # the last level seen before the kill only once the dead host's connections are read to their end: on a
        # loaded machine the observer still read messages stamped 25 s before the kill while the restarted
        # host's first ones were already in (a fresh-clone run with two CPU hogs: 1.06 % 'resumed - last seen')
        if before_count != last_count:
            settled_since, last_count = time.monotonic(), before_count
        settled = time.monotonic() - settled_since >= BEFORE_SETTLED_S
        if (settled and len(first_after) == len(at_resume) == len(names)) or time.monotonic() > deadline:
            break
        time.sleep(POLL_S)
    change, worst = worst_change(at_resume)
    _, worst_after = worst_change(first_after)
    ok = len(at_resume) == len(first_after) == len(names) and change < 0.01
    return ('resumed %d of %d robots (and %d publish again), worst |resumed - at the kill| %s, '
            'first message after: %s (within 1 %%: %s)' % (len(at_resume), len(names), len(first_after), worst,
                                                            worst_after, 'yes' if ok else 'no'))


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
            answer = resumed(robots, killed, float(words[1]), float(words[2]), words[3], int(words[4]))
        else:
            answer = 'unknown command: %s' % line.strip()
        print(answer, flush=True)
    close()


if __name__ == '__main__':
    main()
