#!/usr/bin/env python3
"""The ROS 2 dashboard (and battery_doctor) beside a ROS 2 fleet of N, figures beside a reference measured
in the same run (run inside tools/ros2.sh; the page is read in headless Chromium through Debian's selenium
on /usr/bin/python3).

    tools/ros2.sh python3 tools/benchmark_dashboard.py 250 500          # today's battery_fleet at 250, 500
    tools/ros2.sh python3 tools/benchmark_dashboard.py --doctor 100     # battery_doctor at 100 robots too
    tools/ros2.sh python3 tools/benchmark_dashboard.py --doctor-only 100 --doctor-before OLD.py   # the doctor
        # alone, three runs each of this and an older ros2/doctor.py, in turn, on one fleet
    tools/ros2.sh python3 tools/benchmark_dashboard.py 250 --before OLD.py   # and an older ros2/dashboard.py
    tools/ros2.sh python3 tools/benchmark_dashboard.py --stand-in 1000  # a one-node stand-in fleet host of 1000

For each N: battery_fleet robots:=N at 1 Hz is started and waited for (every robot on
/battery_fleet/states); then battery_dashboard starts and the overview is opened at once: the time from the
dashboard's start to every one of the N cards showing a level (issue 42: within 30 s), then the
dashboard's CPU over the 20 s after that, and again 20 s later (the steady state, with the page open;
issue 42: at most 10 % of a core) and its RSS, beside the
reference: a bare rclpy process subscribed to /battery_fleet/states (what receiving the fleet costs any
Python node), measured in the same window. With --doctor: battery_doctor's wall time on the fleet (issue 40:
100 robots within 15 s), its exit status and how many battery topics it sampled.
"""
import http.client
import json
import os
import re
import signal
import socket
import subprocess
import sys
import threading
import time

TICKS = os.sysconf('SC_CLK_TCK')
CPU_WINDOW_S = 20.0
SETTLE_S = 20.0      # between the start-up's window and the steady state's
FLEET_START_LIMIT_S = 900.0
CARDS_LIMIT_S = 300.0
BARE_FLEET_SUBSCRIBER = '''
import sys, time
import rclpy
from rclpy.qos import QoSProfile, ReliabilityPolicy, DurabilityPolicy
from battery_simulator.msg import BatteryFleetState
rclpy.init()
node = rclpy.create_node('bare_fleet_subscriber')
names = set()
def on(msg):
    names.update(msg.names)
node.create_subscription(BatteryFleetState, '/battery_fleet/states', on, QoSProfile(depth=1,
                         reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE))
want, reported = int(sys.argv[1]), False
try:
    while rclpy.ok():
        rclpy.spin_once(node, timeout_sec=0.5)
        if not reported and len(names) >= want:
            print('all', flush=True)
            reported = True
except (KeyboardInterrupt, Exception):
    pass
'''
#: --stand-in: one lean node with a fleet host's topics for N robots (each robot's battery_status, the
#: simulator's state, transient local battery_low / battery_critical said once) and /battery_fleet/states at
#: 1 Hz: the graph a one-node fleet host of 1000 gives, where today's battery_fleet cannot start 1000
STAND_IN_FLEET = '''
import sys, time
import rclpy
from rclpy.qos import QoSProfile, DurabilityPolicy
from sensor_msgs.msg import BatteryState
from std_msgs.msg import Bool
from battery_simulator.msg import BatteryFleetState, BatterySimState
rclpy.init()
n = int(sys.argv[1])
node = rclpy.create_node('battery_fleet', start_parameter_services=False)
# the fleet's topic first: a participant that joins later learns of 4000 endpoints one announcement after
# another, in the order they were made (under load, minutes for the last ones)
states = node.create_publisher(BatteryFleetState, '/battery_fleet/states', 10)
latched = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)
keep = []
for k in range(n):
    ns = '/robot%d/' % k
    keep.append(node.create_publisher(BatteryState, ns + 'battery_status', 10))
    keep.append(node.create_publisher(BatterySimState, ns + 'battery_simulator/state', 10))
    for level in ('battery_low', 'battery_critical'):
        publisher = node.create_publisher(Bool, ns + level, latched)
        publisher.publish(Bool(data=False))
        keep.append(publisher)
names = ['robot%d' % k for k in range(n)]
def publish():
    msg = BatteryFleetState(names=names)
    msg.header.stamp = node.get_clock().now().to_msg()
    msg.states = [BatteryState(header=msg.header, percentage=0.9 - 0.0005 * k, voltage=12.0, current=-1.5,
                               temperature=25.0, charge=2.7, capacity=3.0, design_capacity=3.0,
                               power_supply_status=2, present=True) for k in range(n)]
    states.publish(msg)
node.create_timer(1.0, publish)
try:
    rclpy.spin(node)
except (KeyboardInterrupt, Exception):
    pass
'''
#: the overview in headless Chromium: prints the seconds until N cards show a level, then waits for stdin
OPEN_PAGE = '''
import sys, time
from selenium import webdriver
from selenium.webdriver.chrome.service import Service
from selenium.webdriver.support.ui import WebDriverWait
options = webdriver.ChromeOptions()
for argument in ('--headless=new', '--no-sandbox', '--disable-gpu', '--window-size=1280,800'):
    options.add_argument(argument)
driver = webdriver.Chrome(options=options, service=Service('/usr/bin/chromedriver'))
COUNT = """return [...document.querySelectorAll('[data-battery] [data-field="percentage"]')]
                  .filter((e) => e.textContent !== '-').length"""
try:
    n, limit = int(sys.argv[2]), float(sys.argv[3])
    deadline = time.monotonic() + limit
    while True:
        try:
            driver.get(sys.argv[1])
            break
        except Exception:
            if time.monotonic() > deadline:
                raise
            time.sleep(0.5)
    print('loaded', flush=True)
    WebDriverWait(driver, max(1.0, deadline - time.monotonic()), 0.25).until(
        lambda d: d.execute_script(COUNT) >= n)
    print('shown', flush=True)
    sys.stdin.readline()
    print(driver.execute_script("return document.querySelectorAll('[data-battery]:not(.stale)').length"), flush=True)
finally:
    driver.quit()
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


def cpu_percents(pids, window_s):
    """{pid: % of a core} over one window of ``window_s`` (a measurement window, not a wait)."""
    before, started = {pid: cpu_seconds(pid) for pid in pids}, time.monotonic()
    time.sleep(window_s)
    elapsed = time.monotonic() - started
    return {pid: 100.0 * (cpu_seconds(pid) - before[pid]) / elapsed for pid in pids}


def start(command, **kwargs):
    kwargs.setdefault('stdout', subprocess.DEVNULL)
    kwargs.setdefault('stderr', subprocess.DEVNULL)
    return subprocess.Popen(command, start_new_session=True, **kwargs)


def stop(process):
    if process is not None and process.poll() is None:
        os.kill(process.pid, signal.SIGINT)
        try:
            process.wait(20.0)
        except subprocess.TimeoutExpired:
            os.kill(process.pid, signal.SIGKILL)
            process.wait()


def free_port():
    with socket.socket() as probe:
        probe.bind(('127.0.0.1', 0))
        return probe.getsockname()[1]


def read_line(process, limit_s):
    """The next line of ``process``'s stdout within ``limit_s`` ('' if none)."""
    line = []
    reader = threading.Thread(target=lambda: line.append(process.stdout.readline()), daemon=True)
    reader.start()
    reader.join(limit_s)
    return line[0].strip() if line else ''


def api_count(port):
    try:
        connection = http.client.HTTPConnection('127.0.0.1', port, timeout=5.0)
        connection.request('GET', '/api/batteries', headers={'Host': '127.0.0.1:%d' % port})
        return len(json.loads(connection.getresponse().read())['batteries'])
    except (OSError, ValueError):
        return -1


#: runs an older ros2/doctor.py (a file, argv[1]) as battery_doctor
OLD_DOCTOR = ('import sys, importlib.util as u; s = u.spec_from_file_location("old_doctor", sys.argv[1]); '
              'm = u.module_from_spec(s); s.loader.exec_module(m); m.main(sys.argv[2:])')


def doctor(rows, n, before=None):
    """battery_doctor's wall time on the fleet; with ``before`` (an older ros2/doctor.py) three runs of each,
    in turn (the load the same for both)."""
    commands = [('battery_doctor', ['battery_doctor'])]
    if before:
        commands.append((os.path.basename(before), [sys.executable, '-c', OLD_DOCTOR, before]))
    for attempt in range(3 if before else 1):
        for label, command in commands:
            began = time.monotonic()
            result = subprocess.run(command, capture_output=True, text=True, timeout=180.0)
            took = time.monotonic() - began
            sampled = len(set(re.findall(r'^sampled +(\S+) ', result.stdout, re.M)))
            listed = len(set(re.findall(r'^publisher +(\S+) +sensor_msgs/msg/BatteryState ', result.stdout, re.M)))
            problems = [line for line in result.stdout.splitlines() if line.startswith(('unsampled:', 'problem:'))]
            rows.append(('%s, %d robots' % (label, n), '%.1f s, exit %d' % (took, result.returncode),
                         '%d of %d battery topics listed sampled, %d problem lines%s (load %.1f)' % (
                             sampled, listed, len(problems), '; ' + problems[0][:100] if problems else '',
                             os.getloadavg()[0]),
                         '<= 15 s, every topic sampled' if n == 100 else ''))


def dashboard(rows, n, with_doctor, dashboards, stand_in, doctor_before=None):
    began = time.monotonic()
    if stand_in:
        fleet = start([sys.executable, '-c', STAND_IN_FLEET, str(n)])
    else:
        fleet = start(['battery_fleet', '--ros-args', '-p', 'robots:=%d' % n, '-p', 'time_scale:=1.0'])
    bare = start([sys.executable, '-c', BARE_FLEET_SUBSCRIBER, str(n)], stdout=subprocess.PIPE, text=True)
    try:
        if read_line(bare, FLEET_START_LIMIT_S) != 'all':
            rows.append(('fleet of %d' % n, 'not every robot on /battery_fleet/states within %g s'
                         % FLEET_START_LIMIT_S, '', ''))
            return
        fleet_up = time.monotonic() - began
        if with_doctor:
            doctor(rows, n, doctor_before)
        for label, command in dashboards:
            measure_dashboard(rows, n, label, command, fleet, bare, fleet_up, stand_in)
    finally:
        stop(bare)
        stop(fleet)


def measure_dashboard(rows, n, label, command, fleet, bare, fleet_up, stand_in):
    port = free_port()
    board = page = None
    try:
        board_started = time.monotonic()
        board = start(command + ['--ros-args', '-p', 'port:=%d' % port])
        page = start(['/usr/bin/python3', '-c', OPEN_PAGE, 'http://127.0.0.1:%d/' % port, str(n),
                      str(CARDS_LIMIT_S)], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True,
                     env=dict(os.environ, PYTHONPATH=''))
        loaded = read_line(page, CARDS_LIMIT_S)
        shown = read_line(page, CARDS_LIMIT_S) if loaded == 'loaded' else ''
        cards_s = time.monotonic() - board_started if shown == 'shown' else float('nan')
        # the start-up's tail (its level subscriptions still being made and matched), then the steady state
        early = cpu_percents([board.pid], CPU_WINDOW_S)[board.pid]
        time.sleep(SETTLE_S)   # a measurement's pause, not a wait for a condition
        cpu = cpu_percents([board.pid, bare.pid, fleet.pid], CPU_WINDOW_S)
        memory = rss_mb(board.pid)
        try:
            page.stdin.write('\n')
            page.stdin.flush()
            fresh = read_line(page, 60.0)
        except OSError:   # the page gave up waiting for the cards
            fresh = 'none'
        rows.append(('%s, %d robots%s, the page open' % (label, n, ' (stand-in host)' if stand_in else ''),
                     '%.1f %% of a core (%.1f %% in the %g s after the cards showed), %.0f MB; every card '
                     '%.1f s after its start' % (cpu[board.pid], early, CPU_WINDOW_S, memory, cards_s),
                     'bare rclpy subscriber of /battery_fleet/states: %.1f %%, %.0f MB; fleet host %.1f %% '
                     '(up in %.0f s); %s of %d fresh on the page, %d in the API' % (
                         cpu[bare.pid], rss_mb(bare.pid), cpu[fleet.pid], fleet_up, fresh or '?', n, api_count(port)),
                     '<= 10 %%, <= 30 s%s' % (' (stand-in fleet)' if stand_in else '')))
    finally:
        if page is not None and page.poll() is None:
            page.stdin.close()
            try:
                page.wait(30.0)
            except subprocess.TimeoutExpired:
                page.kill()
                page.wait()
        stop(board)


class Rows(list):
    """The table's rows; each is also printed as it is measured (a run cut short keeps what it measured)."""

    def append(self, row):
        print(' | '.join(str(cell) for cell in row), flush=True)
        super().append(row)


def take_domain():
    """A ROS domain of this run's own (the tests' lock files: no other run on this machine uses it)."""
    import fcntl
    import tempfile
    for domain in range(101, 201):
        lock = open(os.path.join(tempfile.gettempdir(), 'battery_simulator_ros2_domain_%d.lock' % domain), 'a')
        try:
            fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            lock.close()
            continue
        os.environ['ROS_DOMAIN_ID'] = str(domain)
        return lock
    raise RuntimeError('every ROS domain 101-200 is taken')


def main():
    held = take_domain()   # noqa: F841 (held open, locked, until the run ends)
    arguments = sys.argv[1:]
    with_doctor = '--doctor' in arguments
    dashboards = [('battery_dashboard', ['battery_dashboard'])]
    if '--before' in arguments:   # another version of ros2/dashboard.py, measured after this one on each fleet
        before = arguments.pop(arguments.index('--before') + 1)
        arguments.remove('--before')
        dashboards.append(('%s' % os.path.basename(before), [sys.executable, before]))
    doctor_before = None
    if '--doctor-before' in arguments:
        doctor_before = arguments.pop(arguments.index('--doctor-before') + 1)
        arguments.remove('--doctor-before')
    if '--doctor-only' in arguments:
        with_doctor, dashboards = True, []
    stand_in = '--stand-in' in arguments
    sizes = [int(a) for a in arguments if a not in ('--doctor', '--doctor-only', '--stand-in')] or [250]
    rows = Rows()
    for n in sizes:
        dashboard(rows, n, with_doctor, dashboards, stand_in, doctor_before)
    header = ('measurement', 'figure', 'beside it (same run)', 'target')
    widths = [max(len(str(r[i])) for r in rows + [header]) for i in range(4)]
    print('\nROS 2 dashboard (Fast DDS on 127.0.0.1, %d cores, load average %s)'
          % (os.cpu_count(), ' '.join('%.1f' % x for x in os.getloadavg())))
    for row in [header] + rows:
        print('  '.join(str(cell).ljust(width) for cell, width in zip(row, widths)).rstrip())


if __name__ == '__main__':
    main()
