#!/usr/bin/env python3
"""The ROS 2 section of tools/benchmark.sh (run inside tools/ros2.sh): what one battery_sim costs beside a
bare rclpy timer publisher measured in the same run, and the ROS 2 fleet host at N robots in one process
with every battery_status subscribed (RSS, CPU, launch to every first message, rates).

    tools/benchmark.sh ros2            # N = 10, 100 and 250
    tools/ros2.sh python3 tools/ros2_benchmark.py 10 100
    tools/ros2.sh python3 tools/ros2_benchmark.py dashboard   # battery_dashboard, 100 robots, the page open
"""
import http.client
import json
import os
import signal
import socket
import subprocess
import sys
import threading
import time

import rclpy
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import BatteryState

CPU_WINDOW_S = 20.0
RATE_WINDOW_S = 20.0
TICKS = os.sysconf('SC_CLK_TCK')
BARE_PUBLISHER = '''
import rclpy
from rclpy.node import Node
from sensor_msgs.msg import BatteryState
rclpy.init()
node = Node('bare_timer_publisher')
pub = node.create_publisher(BatteryState, 'bare/battery_status', 10)
node.create_timer(1.0, lambda: pub.publish(BatteryState(voltage=12.0, percentage=0.5)))
try:
    rclpy.spin(node)
except (KeyboardInterrupt, Exception):
    pass
'''


def cpu_seconds(pid):
    with open('/proc/%d/stat' % pid) as stream:
        fields = stream.read().rsplit(')', 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / TICKS


def rss_mb(pid):
    with open('/proc/%d/status' % pid) as stream:
        for line in stream:
            if line.startswith('VmRSS:'):
                return int(line.split()[1]) / 1024.0
    return float('nan')


def cpu_percent(pid, window_s):
    before, started = cpu_seconds(pid), time.monotonic()
    time.sleep(window_s)   # a measurement window, not a wait for a condition
    return 100.0 * (cpu_seconds(pid) - before) / (time.monotonic() - started)


class Listener:
    """Counts every message of the battery_status topics it is given, in a thread of its own."""

    def __init__(self, topics):
        self.node = Node('benchmark_listener')
        self.first = {}
        self.counts = {topic: 0 for topic in topics}
        qos = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)
        for topic in topics:
            self.node.create_subscription(BatteryState, topic, lambda msg, t=topic: self._on(t), qos)
        self.executor = SingleThreadedExecutor()
        self.executor.add_node(self.node)
        threading.Thread(target=self.executor.spin, daemon=True).start()

    def _on(self, topic):
        self.counts[topic] += 1
        self.first.setdefault(topic, time.monotonic())

    def close(self):
        self.executor.shutdown()
        self.node.destroy_node()


def start(command):
    return subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)


def stop(process):
    if process.poll() is None:
        os.kill(process.pid, signal.SIGINT)
        try:
            process.wait(10.0)
        except subprocess.TimeoutExpired:
            os.kill(process.pid, signal.SIGKILL)
            process.wait()


def one_battery(rows):
    listener = Listener(['/bench1/battery_status', '/bare/battery_status'])
    sim = start(['battery_sim', '--ros-args', '-r', '__ns:=/bench1'])
    bare = start([sys.executable, '-c', BARE_PUBLISHER])
    try:
        deadline = time.monotonic() + 30.0
        while len(listener.first) < 2 and time.monotonic() < deadline:
            time.sleep(0.1)
        time.sleep(3.0)   # settle after start-up
        cpu = {}
        threads = [threading.Thread(target=lambda p=p: cpu.__setitem__(p.pid, cpu_percent(p.pid, CPU_WINDOW_S)))
                   for p in (sim, bare)]
        for thread in threads:
            thread.start()
        for thread in threads:
            thread.join()
        rows.append(('one battery (battery_sim: 2 nodes, 10 Hz model, 1 Hz status)',
                     '%.1f %% of a core, %.0f MB' % (cpu[sim.pid], rss_mb(sim.pid)),
                     'bare rclpy timer publisher: %.1f %%, %.0f MB' % (cpu[bare.pid], rss_mb(bare.pid)), ''))
    finally:
        stop(sim)
        stop(bare)
        listener.close()


def fleet(rows, n):
    topics = ['/bench%d/battery_status' % k for k in range(n)]
    listener = Listener(topics)
    started = time.monotonic()
    host = start(['battery_fleet', '--ros-args', '-p', 'robots:=%d' % n, '-p', 'prefix:=bench',
                  '-p', 'initial_percentage:=90.0'])
    try:
        deadline = started + 120.0
        while len(listener.first) < n and time.monotonic() < deadline and host.poll() is None:
            time.sleep(0.1)
        up_s = max(listener.first.values()) - started if len(listener.first) == n else float('nan')
        time.sleep(2.0)
        marks = dict(listener.counts)
        cpu = cpu_percent(host.pid, RATE_WINDOW_S)
        rates = [(listener.counts[t] - marks[t]) / RATE_WINDOW_S for t in topics]
        target = n == 100
        rows.append(('fleet host, %d robots (one process, every status subscribed)' % n,
                     '%.0f MB, %.1f %% of a core' % (rss_mb(host.pid), cpu),
                     'every first message %.1f s after launch; rates %.3f .. %.3f Hz (%d of %d)' % (
                         up_s, min(rates), max(rates), len(listener.first), n),
                     '<= 350 MB, <= 10 %, <= 10 s, within 1 %' if target else ''))
    finally:
        stop(host)
        listener.close()


#: ROS 1's figure (docs/dashboard.md, tools/graph_benchmark.py): the ROS 2 dashboard's target is 1.5 times it
ROS1_DASHBOARD_CPU = 3.2
#: the overview in headless Chromium (Debian's selenium on /usr/bin/python3), open until stdin closes
OPEN_PAGE = '''
import sys, time
from selenium import webdriver
from selenium.webdriver.chrome.service import Service
from selenium.webdriver.support.ui import WebDriverWait
options = webdriver.ChromeOptions()
for argument in ('--headless=new', '--no-sandbox', '--disable-gpu', '--window-size=1280,800'):
    options.add_argument(argument)
driver = webdriver.Chrome(options=options, service=Service('/usr/bin/chromedriver'))
try:
    driver.get(sys.argv[1])
    WebDriverWait(driver, 120, 0.2).until(lambda d: d.execute_script(
        "return document.querySelectorAll('[data-battery]').length") >= int(sys.argv[2]))
    print('open', flush=True)
    sys.stdin.readline()
    print(driver.execute_script("return document.querySelectorAll('[data-battery]:not(.stale)').length"), flush=True)
finally:
    driver.quit()
'''


def dashboard_batteries(port):
    try:
        connection = http.client.HTTPConnection('127.0.0.1', port, timeout=5.0)
        connection.request('GET', '/api/batteries', headers={'Host': '127.0.0.1:%d' % port})
        return len(json.loads(connection.getresponse().read())['batteries'])
    except (OSError, ValueError):
        return -1


def free_port():
    with socket.socket() as probe:
        probe.bind(('127.0.0.1', 0))
        return probe.getsockname()[1]


def dashboard(rows, n=100):
    """battery_dashboard beside a fleet of ``n`` at 1 Hz with the overview open in headless Chromium."""
    port = free_port()
    host = start(['battery_fleet', '--ros-args', '-p', 'robots:=%d' % n, '-p', 'prefix:=bench'])
    board = start(['battery_dashboard', '--ros-args', '-p', 'port:=%d' % port])
    page = None
    try:
        deadline = time.monotonic() + 120.0
        while dashboard_batteries(port) < n and time.monotonic() < deadline:
            time.sleep(0.5)
        page = subprocess.Popen(['/usr/bin/python3', '-c', OPEN_PAGE, 'http://127.0.0.1:%d/' % port, str(n)],
                                stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True,
                                env=dict(os.environ, PYTHONPATH=''))
        assert page.stdout.readline().strip() == 'open', 'the page did not show %d batteries' % n
        time.sleep(5.0)   # settle after start-up
        cpu = {}
        threads = [threading.Thread(target=lambda p=p: cpu.__setitem__(p.pid, cpu_percent(p.pid, CPU_WINDOW_S)))
                   for p in (board, host)]
        for thread in threads:
            thread.start()
        for thread in threads:
            thread.join()
        memory = rss_mb(board.pid)
        page.stdin.write('\n')
        page.stdin.flush()
        fresh = page.stdout.readline().strip()
        page.wait(30.0)
        rows.append(('battery_dashboard: %d batteries at 1 Hz, the page open (%.0f s)' % (n, CPU_WINDOW_S),
                     '%.1f %% of a core, %.0f MB' % (cpu[board.pid], memory),
                     'ROS 1 (docs): %.1f %%; %s of %d fresh on the page; fleet host %.1f %%' % (
                         ROS1_DASHBOARD_CPU, fresh, n, cpu[host.pid]),
                     '<= %.1f %% (1.5 x ROS 1)' % (1.5 * ROS1_DASHBOARD_CPU)))
    finally:
        if page is not None and page.poll() is None:   # stdin closed: it quits its browser and ends
            page.stdin.close()
            try:
                page.wait(30.0)
            except subprocess.TimeoutExpired:
                page.kill()
                page.wait()
        stop(board)
        stop(host)


def main():
    arguments = sys.argv[1:]
    sizes = [int(a) for a in arguments if a != 'dashboard'] or ([] if arguments else [10, 100, 250])
    rclpy.init()
    rows = []
    if 'dashboard' in arguments:
        dashboard(rows)
    else:
        one_battery(rows)
    for n in sizes:
        fleet(rows, n)
    rclpy.shutdown()
    widths = [max(len(str(r[i])) for r in rows + [('measurement', 'figure', 'beside it', 'target')])
              for i in range(4)]
    print('\nROS 2 (rclpy %s, Fast DDS on 127.0.0.1, %d cores)' % (os.environ.get('ROS_DISTRO', '?'), os.cpu_count()))
    for row in [('measurement', 'figure', 'beside it', 'target')] + rows:
        print('  '.join('%-*s' % (w, c) for w, c in zip(widths, row)))


if __name__ == '__main__':
    main()
