#!/usr/bin/env python3
"""The ROS 2 section of tools/benchmark.sh (run inside tools/ros2.sh): what one battery_sim costs beside a
bare rclpy timer publisher measured in the same run, and the ROS 2 fleet host at N robots in one process
with every battery_status subscribed (RSS, CPU, launch to every first message, rates).

    tools/benchmark.sh ros2            # N = 100, 250, 500 and 1000
    tools/ros2.sh python3 tools/ros2_benchmark.py 100 1000 [--lean-dds]

Each fleet row: the host's RSS and CPU at steady state (1 Hz) beside a bare rclpy timer publisher measured in the
same window, launch to every robot's first battery_status (a listener process of its own), /battery_fleet/states'
rate, SIGINT to exit, and when /battery_fleet/states first held every robot (what the host itself published: the
listener's own discovery of 27 endpoints a robot, with a subscription per robot, is part of its first figure).
--lean-dds: every process's Fast DDS endpoints with histories allocated as used (LEAN_ENDPOINTS; the fleet host
always has them, ros2/fleet_dds.py).
    tools/ros2.sh python3 tools/ros2_benchmark.py dashboard [N ...]   # battery_dashboard beside a fleet of N (100),
                                                                      # the page open, its CPU in 20 s windows
                                                                      # for DASHBOARD_WATCH_S (300 s; the last counts)
    tools/ros2.sh python3 tools/ros2_benchmark.py endpoints [N ...]   # what a robot's 27 DDS endpoints cost in one
                                                                      # rclpy node (no battery, no Python of ours), N
                                                                      # robots (200), with the fleet host's Fast DDS
                                                                      # profile beside the profile in force alone
    tools/ros2.sh python3 tools/ros2_benchmark.py gauge [N ...]       # the fleet host at N robots (1000) with the
                                                                      # learning gauge beside the default one: CPU
"""
import http.client
import json
import os
import signal
import socket
import subprocess
import sys
import tempfile
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


def cpu_percent(pids, window_s):
    """{pid: % of a core} of each of ``pids`` over one window, the same for all (graph_benchmark.py's twin)."""
    before, started = {pid: cpu_seconds(pid) for pid in pids}, time.monotonic()
    time.sleep(window_s)   # a measurement window, not a wait for a condition
    elapsed_s = time.monotonic() - started
    return {pid: 100.0 * (cpu_seconds(pid) - before[pid]) / elapsed_s for pid in pids}


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
        cpu = cpu_percent([sim.pid, bare.pid], CPU_WINDOW_S)
        rows.append(('one battery (battery_sim: 2 nodes, 10 Hz model, 1 Hz status)',
                     '%.1f %% of a core, %.0f MB' % (cpu[sim.pid], rss_mb(sim.pid)),
                     'bare rclpy timer publisher: %.1f %%, %.0f MB' % (cpu[bare.pid], rss_mb(bare.pid)), ''))
    finally:
        stop(sim)
        stop(bare)
        listener.close()


#: Fast DDS endpoints with a history allocated as it is used (what tools/ros2_benchmark.py --lean-dds adds to the
#: profile in force): a reader costs 78 KB by default, 30 KB so; a service 86 KB, 37 KB (2000 of each, measured)
LEAN_ENDPOINTS = """
  <data_reader profile_name="lean_reader" is_default_profile="true"><topic><resourceLimitsQos>
    <allocated_samples>1</allocated_samples><max_samples>100</max_samples></resourceLimitsQos></topic>
    <historyMemoryPolicy>DYNAMIC</historyMemoryPolicy></data_reader>
  <data_writer profile_name="lean_writer" is_default_profile="true"><topic><resourceLimitsQos>
    <allocated_samples>1</allocated_samples></resourceLimitsQos></topic>
    <historyMemoryPolicy>DYNAMIC</historyMemoryPolicy></data_writer>
"""


def lean_dds_profile():
    """The profile in force (FASTDDS_DEFAULT_PROFILES_FILE) with LEAN_ENDPOINTS added: the path of a copy."""
    with open(os.environ['FASTDDS_DEFAULT_PROFILES_FILE'], encoding='utf-8') as stream:
        text = stream.read()
    path = os.path.join(tempfile.mkdtemp(prefix='ros2_benchmark_'), 'fastdds_lean_endpoints.xml')
    with open(path, 'w', encoding='utf-8') as stream:
        stream.write(text.replace('</profiles>', LEAN_ENDPOINTS + '</profiles>'))
    return path


class FleetListener:
    """Every robot's first battery_status, and /battery_fleet/states' messages, in a process of its own (a
    thousand subscriptions in one rclpy executor would lag behind and make the host look slow)."""

    CODE = """
import json, sys, time, rclpy
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import BatteryState
from battery_simulator.msg import BatteryFleetState
rclpy.init()
node = Node('benchmark_fleet_listener', start_parameter_services=False, enable_rosout=False)
topics = sys.argv[1].split(',')
first, stamped, states = {}, {}, []
qos = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE)
subs = {}
def on_status(topic, msg):
    if topic in subs:
        first[topic] = time.time()
        stamped[topic] = msg.header.stamp.sec + 1e-9 * msg.header.stamp.nanosec
        node.destroy_subscription(subs.pop(topic))   # one message each is all this needs
for topic in topics:
    subs[topic] = node.create_subscription(BatteryState, topic, lambda msg, t=topic: on_status(t, msg), qos)
node.create_subscription(BatteryFleetState, '/battery_fleet/states', lambda msg: states.append((time.time(), len(msg.names))), 10)
try:   # a callback as its message comes: rclpy's SingleThreadedExecutor ran one callback a wake-up, each rebuilding
    from rclpy.experimental import EventsExecutor   # its wait set over every subscription (1000: the last first
    executor = EventsExecutor()                     # message read 5-10 s after it came; its stamp says when it went)
except ImportError:
    from rclpy.executors import SingleThreadedExecutor
    executor = SingleThreadedExecutor()
executor.add_node(node)
import os
while not os.path.exists(sys.argv[2]):   # the benchmark creates it when it is done
    executor.spin_once(timeout_sec=0.2)
print(json.dumps({'first': first, 'stamped': stamped, 'states': states}))
"""

    def __init__(self, topics):
        self.done = os.path.join(tempfile.mkdtemp(prefix='ros2_benchmark_listener_'), 'done')
        self.process = subprocess.Popen([sys.executable, '-c', self.CODE, ','.join(topics), self.done],
                                        stdout=subprocess.PIPE, text=True)

    def result(self):
        open(self.done, 'w').close()
        return json.loads(self.process.communicate(timeout=60.0)[0])


def fleet_host(parameters, environment=None):
    """battery_fleet started with ``parameters`` (name:=value each): (the process, the list its output lines are
    read into, in a thread of its own)."""
    host = subprocess.Popen(['battery_fleet', '--ros-args'] + [word for p in parameters for word in ('-p', p)],
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=environment)
    lines = []
    threading.Thread(target=lambda: lines.extend(host.stdout), daemon=True).start()
    return host, lines


def wait_until_ready(host, lines, within_s=600.0):
    """Until the host says it is ready (or ends, or ``within_s`` passed)."""
    deadline = time.monotonic() + within_s
    while not any('battery_fleet ready' in line for line in lines) and host.poll() is None and \
            time.monotonic() < deadline:
        time.sleep(0.2)


def fleet(rows, n, lean_dds=False, start_within_s=600.0):
    """The host at ``n`` robots beside a bare rclpy publisher measured in the same run: RSS and CPU at steady
    state (1 Hz), launch to every robot's first battery_status, /battery_fleet/states' rate, SIGINT to exit."""
    prefix = 'fb%d' % n
    topics = ['/%s%d/battery_status' % (prefix, k) for k in range(n)]
    environment = dict(os.environ)
    if lean_dds:
        environment['FASTDDS_DEFAULT_PROFILES_FILE'] = lean_dds_profile()
    listener = FleetListener(topics)
    time.sleep(2.0)   # the listener's subscriptions exist before the host starts
    started = time.time()
    host, lines = fleet_host(['robots:=%d' % n, 'prefix:=' + prefix, 'initial_percentage:=90.0'], environment)
    bare = start([sys.executable, '-c', BARE_PUBLISHER])
    try:
        wait_until_ready(host, lines, start_within_s)
        ready_s = time.time() - started
        time.sleep(10.0)   # settle after start-up
        cpu = cpu_percent([host.pid, bare.pid], CPU_WINDOW_S)
        memory = rss_mb(host.pid)
        stopped = time.monotonic()
        os.kill(host.pid, signal.SIGINT)
        try:
            host.wait(30.0)
            stop_s = time.monotonic() - stopped
        except subprocess.TimeoutExpired:
            stop_s = float('nan')
        seen = listener.result()
        firsts = [seen['first'][t] - started for t in topics if t in seen['first']]
        sent = [seen['stamped'][t] - started for t in topics if t in seen['stamped']]
        states = [at for at, count in seen['states'] if count == n]
        rate = (len(states) - 1) / (states[-1] - states[0]) if len(states) > 2 else float('nan')
        whole = '%.1f s' % (states[0] - started) if states else 'never'   # every robot's state in one message
        rows.append(('fleet host, %d robots%s' % (n, ', lean DDS endpoints' if lean_dds else ''),
                     '%.0f MB, %.1f %% of a core; ready %.1f s; ended %.2f s after SIGINT' % (
                         memory, cpu[host.pid], ready_s, stop_s),
                     'every first battery_status %s (%d of %d; stamped by %s), all %d in fleet states %s; fleet '
                     'states %.2f Hz; bare publisher %.1f %%, %.0f MB'
                     % ('%.1f s' % max(firsts) if len(firsts) == n else 'not all', len(firsts), n,
                        '%.1f s' % max(sent) if sent else '-', n, whole, rate, cpu[bare.pid], rss_mb(bare.pid)),
                     '<= 400 MB, <= 40 %, <= 20 s, 1 Hz, <= 2 s' if n == 1000 else ''))
    finally:
        if host.poll() is None:
            os.kill(host.pid, signal.SIGKILL)
            host.wait()
        stop(bare)
        if listener.process.poll() is None:
            listener.process.kill()


#: N robots' 27 endpoints in one node, as a fleet host holds them (each robot's names: 6 services and the action's 3,
#: a reader and a writer each; cmd_vel, charger_contact; battery_status, battery_state, low, critical, the state, the
#: action's feedback and status), nothing else: the process's RSS before and after, as JSON
ENDPOINTS_SCRIPT = """
import contextlib, gc, json, os, sys, time
from battery_simulator.ros2.fleet_dds import fleet_profile
import rclpy
from rclpy.action import ActionServer
from battery_simulator.action import BatterySim
from battery_simulator.msg import BatterySimState
from battery_simulator.srv import InjectFault, Predict, SetLoad, SetState
from geometry_msgs.msg import Twist
from sensor_msgs.msg import BatteryState
from std_msgs.msg import Bool
from std_srvs.srv import SetBool, Trigger
def rss_kb():
    with open('/proc/self/smaps_rollup') as stream:
        return next(int(line.split()[1]) for line in stream if line.startswith('Rss:'))
with fleet_profile() if sys.argv[2] == 'fleet' else contextlib.nullcontext():   # read as the participant is made
    rclpy.init()
    node = rclpy.create_node('endpoints_benchmark')
entities = []
def robot(name):
    for kind, service in ((SetLoad, 'set_load'), (SetBool, 'set_charging'), (SetState, 'set_state'),
                          (Trigger, 'reset'), (InjectFault, 'inject_fault'), (Predict, 'predict')):
        entities.append(node.create_service(kind, name + service, lambda request, response: response))
    entities.append(ActionServer(node, BatterySim, name + 'battery_simulator', execute_callback=lambda goal: None))
    for kind, topic in ((Twist, 'cmd_vel'), (Bool, 'charger_contact')):
        entities.append(node.create_subscription(kind, name + topic, lambda msg: None, 10))
    for kind, topic in ((BatteryState, 'battery_status'), (BatteryState, 'battery_state'), (Bool, 'battery_low'),
                        (Bool, 'battery_critical'), (BatterySimState, 'battery_sim_state')):
        entities.append(node.create_publisher(kind, name + topic, 10))
robot('/warm_up/')   # every type's support loaded before the first figure
gc.collect()
before = rss_kb()
started = time.process_time()
for k in range(int(sys.argv[1])):
    robot('/ep%d/' % k)
created = time.process_time() - started
gc.collect()
time.sleep(1.0)
print(json.dumps({'before_kb': before, 'after_kb': rss_kb(), 'cpu_s': created}))
sys.stdout.flush()
os._exit(0)   # the figures are taken; rclpy's teardown of thousands of entities is not measured
"""
ENDPOINTS_A_ROBOT = 27


def endpoints(rows, n=200):
    """What a robot's 27 endpoints cost in one node with the fleet host's Fast DDS profile (ros2/fleet_dds.py),
    beside the same under the profile in force alone, in the same run; and 1000 robots' endpoints so."""
    figures = {}
    for profile in ('in force', 'fleet'):
        out = subprocess.run([sys.executable, '-c', ENDPOINTS_SCRIPT, str(n), profile], capture_output=True,
                             text=True, timeout=600).stdout
        figures[profile] = json.loads(out.strip().splitlines()[-1])
    for profile in ('fleet', 'in force'):
        figure = figures[profile]
        robot_kb = (figure['after_kb'] - figure['before_kb']) / n
        rows.append(('%d robots\' endpoints in one node, %s' % (
                         n, 'the fleet host\'s profile' if profile == 'fleet' else 'the profile in force alone'),
                     '%.0f KB a robot, %.1f KB an endpoint; created in %.1f s of CPU' % (
                         robot_kb, robot_kb / ENDPOINTS_A_ROBOT, figure['cpu_s']),
                     'so 1000 robots: %.0f MB with the interpreter\'s %.0f MB' % (
                         (figure['before_kb'] + 1000 * robot_kb) / 1024, figure['before_kb'] / 1024),
                     '<= 400 MB for the whole host at 1000' if profile == 'fleet' else 'reference'))


#: how long the dashboard's CPU is watched with the page open, CPU_WINDOW_S at a time (the last window is the figure)
DASHBOARD_WATCH_S = float(os.environ.get('DASHBOARD_WATCH_S', '300'))
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


def levels_settled(n, started, within_s=600.0):
    """When the dashboard had subscribed to every robot's battery_low and battery_critical (the last it makes):
    steady state starts then. Until then each new subscription's first (transient local) message wakes it."""
    node = Node('benchmark_levels_watch', start_parameter_services=False, enable_rosout=False)
    try:
        names = ['/bench%d/%s' % (k, level) for k in range(n) for level in ('battery_low', 'battery_critical')]
        deadline = started + within_s
        while time.monotonic() < deadline:
            names = [name for name in names if node.count_subscribers(name) == 0]
            if not names:
                return '%.1f s after its start' % (time.monotonic() - started)
            time.sleep(1.0)
        return 'not within %g s (%d left)' % (within_s, len(names))
    finally:
        node.destroy_node()


def dashboard(rows, n=100):
    """battery_dashboard beside a fleet of ``n`` at 1 Hz with the overview open in headless Chromium: the dashboard
    is started once the fleet host is ready, and timed to every battery in its API (its cards)."""
    port = free_port()
    host, lines = fleet_host(['robots:=%d' % n, 'prefix:=bench'])
    board = page = None
    try:
        wait_until_ready(host, lines)
        started = time.monotonic()
        board = start(['battery_dashboard', '--ros-args', '-p', 'port:=%d' % port])
        deadline = started + 300.0
        while dashboard_batteries(port) < n and time.monotonic() < deadline:
            time.sleep(0.5)
        cards_s = time.monotonic() - started
        page = subprocess.Popen(['/usr/bin/python3', '-c', OPEN_PAGE, 'http://127.0.0.1:%d/' % port, str(n)],
                                stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True,
                                env=dict(os.environ, PYTHONPATH=''))
        assert page.stdout.readline().strip() == 'open', 'the page did not show %d batteries' % n
        levels_s = levels_settled(n, started)
        time.sleep(5.0)   # settle after start-up
        # windows one after the other: with a fleet of 1000 DDS matches the dashboard's 2000 level readers against
        # the host's 27 000 endpoints for minutes after they exist (both processes busy), so the last is the figure
        windows = []
        for _ in range(max(1, int(DASHBOARD_WATCH_S / CPU_WINDOW_S))):
            cpu = cpu_percent([board.pid, host.pid], CPU_WINDOW_S)
            windows.append(cpu[board.pid])
        memory = rss_mb(board.pid)
        page.stdin.write('\n')
        page.stdin.flush()
        fresh = page.stdout.readline().strip()
        page.wait(30.0)
        rows.append(('battery_dashboard: %d batteries at 1 Hz, the page open (%.0f s)' % (n, CPU_WINDOW_S),
                     '%.1f %% of a core, %.0f MB (the last of %d windows: %s); every battery in its API %.1f s '
                     'after its start, every level topic subscribed %s' % (
                         cpu[board.pid], memory, len(windows), ', '.join('%.1f' % w for w in windows), cards_s,
                         levels_s),
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
        if board is not None:
            stop(board)
        stop(host)


#: the gauges gauge_cost compares: the default (ideal: the truth shown) and tools/gauge_benchmark.py's learning gauge
GAUGE_CONFIGS = {'ideal': 'preset: lg_hg2_3s1p\ngauge: {model: ideal}\n',
                 'learning': 'preset: lg_hg2_3s1p\ngauge: {model: learning, current_offset_a: 0.01, '
                             'capacity_error: 0.05}\n'}
GAUGE_RUNS = 2


def gauge_cost(rows, n, start_within_s=600.0):
    """The fleet host's CPU at ``n`` robots with the learning gauge beside the same host with the default gauge
    (ideal), at steady state (its 1 Hz updates, every battery_status published), GAUGE_RUNS runs of each,
    interleaved: issue 43's "a fleet of 1000 with it within 10 % of the fleet's cost without it" as a fleet costs
    (tools/gauge_benchmark.py measures Battery.update alone, at 10 Hz)."""
    directory = tempfile.mkdtemp(prefix='gauge_cost_')
    paths = {}
    for gauge, text in GAUGE_CONFIGS.items():
        paths[gauge] = os.path.join(directory, gauge + '.yaml')
        with open(paths[gauge], 'w') as stream:
            stream.write(text)
    cpu = {gauge: [] for gauge in GAUGE_CONFIGS}
    for _ in range(GAUGE_RUNS):
        for gauge, path in paths.items():
            host, lines = fleet_host(['robots:=%d' % n, 'prefix:=gc', 'config:=' + path, 'initial_percentage:=90.0'])
            try:
                wait_until_ready(host, lines, start_within_s)
                time.sleep(10.0)   # settle after start-up
                cpu[gauge].append(cpu_percent([host.pid], CPU_WINDOW_S)[host.pid])
            finally:
                stop(host)
    for path in paths.values():
        os.remove(path)
    os.rmdir(directory)
    ideal, learning = (sum(cpu[g]) / len(cpu[g]) for g in ('ideal', 'learning'))
    rows.append(('fleet host, %d robots, learning gauge' % n,
                 '%.1f %% of a core (%s), %.3fx the default gauge' % (learning, ', '.join('%.1f' % c for c in
                                                                                        cpu['learning']),
                                                                     learning / ideal),
                 'default (ideal) gauge %.1f %% (%s)' % (ideal, ', '.join('%.1f' % c for c in cpu['ideal'])),
                 '<= 1.10x'))


def main():
    arguments = sys.argv[1:]
    lean_dds = '--lean-dds' in arguments
    sizes = [int(a) for a in arguments if a.isdigit()]
    rclpy.init()
    rows = []
    if 'dashboard' in arguments:
        for n in sizes or [100]:
            dashboard(rows, n)
    elif 'endpoints' in arguments:
        for n in sizes or [200]:
            endpoints(rows, n)
    elif 'gauge' in arguments:
        for n in sizes or [1000]:
            gauge_cost(rows, n)
    else:
        one_battery(rows)
        for n in sizes or [100, 250, 500, 1000]:
            fleet(rows, n, lean_dds)
    rclpy.shutdown()
    widths = [max(len(str(r[i])) for r in rows + [('measurement', 'figure', 'beside it', 'target')])
              for i in range(4)]
    print('\nROS 2 (rclpy %s, Fast DDS on 127.0.0.1, %d cores, load average %.1f at the end)' % (
        os.environ.get('ROS_DISTRO', '?'), os.cpu_count(), os.getloadavg()[0]))
    for row in [('measurement', 'figure', 'beside it', 'target')] + rows:
        print('  '.join('%-*s' % (w, c) for w, c in zip(widths, row)))


if __name__ == '__main__':
    main()
