"""Figures of the running ROS graph, each beside a bare reference where one makes sense.

Run through ``tools/benchmark.py --graph`` (needs the devel space sourced). It
starts its own master on a free port, starts every launch file it measures as
a process group of its own, and ends each by its pid.
"""
import http.client
import json
import os
import random
import resource
import signal
import socket
import statistics
import subprocess
import sys
import threading
import time
import xmlrpc.client

import actionlib
import rosgraph
import rospy
from sensor_msgs.msg import BatteryState
from std_msgs.msg import Bool

from battery_simulator.msg import battery_simAction, battery_simGoal
from battery_simulator.srv import Predict, PredictRequest

REFERENCE_NODE = '''
import sys, rospy
from sensor_msgs.msg import BatteryState
rospy.init_node('reference_publisher')
pub = rospy.Publisher(sys.argv[2], BatteryState, queue_size=10)
msg = BatteryState()
def tick(event):
    msg.header.stamp = rospy.Time.now()
    pub.publish(msg)
rospy.Timer(rospy.Duration(1.0 / float(sys.argv[1])), tick)
rospy.spin()
'''


def free_port():
    with socket.socket() as sock:
        sock.bind(('127.0.0.1', 0))
        return sock.getsockname()[1]


class Processes:
    """Child process groups, each ended by its pid (SIGINT, then SIGKILL)."""

    def __init__(self):
        self._children = []

    def start(self, command):
        child = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                                 start_new_session=True)
        self._children.append(child)
        return child

    def stop(self, child):
        if child.poll() is None:
            os.killpg(child.pid, signal.SIGINT)
            try:
                child.wait(timeout=20.0)
            except subprocess.TimeoutExpired:
                os.killpg(child.pid, signal.SIGKILL)
                child.wait()
        self._children.remove(child)

    def stop_all(self):
        for child in reversed(list(self._children)):
            self.stop(child)


def launch(processes, launch_file, namespace=None, **args):
    command = ['roslaunch', 'battery_simulator', launch_file] + ['%s:=%s' % item for item in args.items()]
    if namespace:
        command = ['env', 'ROS_NAMESPACE=' + namespace] + command
    return processes.start(command)


def wait_until(condition, timeout_s, what):
    deadline = time.monotonic() + timeout_s
    while not condition():
        if time.monotonic() > deadline:
            raise RuntimeError('timed out waiting for %s' % what)
        time.sleep(0.005)


class Arrivals:
    """Wall arrival times (and messages) of one topic."""

    def __init__(self, topic, msg_type=BatteryState):
        self.lock = threading.Lock()
        self.items = []
        self.sub = rospy.Subscriber(topic, msg_type, self._on, queue_size=1000, tcp_nodelay=True)

    def _on(self, msg):
        with self.lock:
            self.items.append((time.monotonic(), msg))

    def since(self, index):
        with self.lock:
            return self.items[index:]

    def count(self):
        with self.lock:
            return len(self.items)

    def close(self):
        self.sub.unregister()


def rate_figures(topics, rate_hz, duration_s):
    """[(rate error %, p99 |interval - period| in ms)] per topic, all recorded over the same ``duration_s``."""
    recorders = [Arrivals(topic) for topic in topics]
    wait_until(lambda: all(r.count() >= 3 for r in recorders), 30.0, ', '.join(topics))
    starts = [r.count() for r in recorders]
    time.sleep(duration_s)
    figures = []
    for recorder, start in zip(recorders, starts):
        times = [t for t, _ in recorder.since(start)]
        recorder.close()
        intervals = [b - a for a, b in zip(times, times[1:])]
        measured_hz = len(intervals) / (times[-1] - times[0])
        deviations = sorted(abs(i - 1.0 / rate_hz) for i in intervals)
        p99 = deviations[min(len(deviations) - 1, int(0.99 * len(deviations)))]
        figures.append((100.0 * abs(measured_hz - rate_hz) / rate_hz, 1000.0 * p99))
    return figures


def process_ids(node_names):
    master = rosgraph.Master('/graph_benchmark')
    pids = {}
    for name in node_names:
        uri = master.lookupNode(name)
        pids[name] = xmlrpc.client.ServerProxy(uri).getPid('/graph_benchmark')[2]
    return pids


def cpu_seconds(pid):
    with open('/proc/%d/stat' % pid) as stream:
        fields = stream.read().rsplit(')', 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf('SC_CLK_TCK')


def rss_mb(pid):
    with open('/proc/%d/status' % pid) as stream:
        for line in stream:
            if line.startswith('VmRSS:'):
                return int(line.split()[1]) / 1024.0
    return 0.0


def cpu_percent(pids, duration_s):
    before = {pid: cpu_seconds(pid) for pid in pids}
    time.sleep(duration_s)
    return {pid: 100.0 * (cpu_seconds(pid) - before[pid]) / duration_s for pid in pids}


# -- the measurements -------------------------------------------------------------

def measure_rates(processes, rows):
    for rate_hz in (1.0, 100.0, 500.0):
        duration_s = 60.0 if rate_hz < 10 else 20.0
        ns = 'rate%d' % rate_hz
        sim = launch(processes, 'sim.launch', ns, rate=rate_hz)
        reference = processes.start([sys.executable, '-c', REFERENCE_NODE, str(rate_hz), '/%s/reference' % ns])
        try:   # side by side: both recorded over the same window
            (error, jitter), (ref_error, ref_jitter) = rate_figures(
                ['/%s/battery_status' % ns, '/%s/reference' % ns], rate_hz, duration_s)
        finally:
            processes.stop(reference)
            processes.stop(sim)
        rows.append(('battery_status rate error at %g Hz' % rate_hz, '%.3f %%' % error,
                     'reference %.3f %%' % ref_error, '< 0.5 %'))
        rows.append(('battery_status p99 jitter at %g Hz' % rate_hz, '%.2f ms' % jitter,
                     'reference %.2f ms (%.2fx)' % (ref_jitter, jitter / ref_jitter if ref_jitter else float('nan')),
                     '<= 1.2x reference'))


def first_feedback_ms(client, charge):
    """Wall ms from send_goal to the goal's first feedback."""
    got = threading.Event()
    sent = time.monotonic()
    client.send_goal(battery_simGoal(charge_state=charge), feedback_cb=lambda feedback: got.set())
    got.wait(5.0)
    return 1000.0 * (time.monotonic() - sent)


def measure_goals(processes, rows, repeats=40):
    sim = launch(processes, 'sim.launch', 'goals', time_scale=1, initial_percentage=50)
    try:
        client = actionlib.SimpleActionClient('/goals/battery_simulator', battery_simAction)
        other = actionlib.SimpleActionClient('/goals/battery_simulator', battery_simAction)
        assert client.wait_for_server(rospy.Duration(30.0)) and other.wait_for_server(rospy.Duration(30.0))
        idle, preempting = [], []
        for index in range(repeats):
            charge = bool(index % 2)
            idle.append(first_feedback_ms(client, charge))
            preempting.append(first_feedback_ms(other, not charge))   # preempts client's goal
            client.wait_for_result(rospy.Duration(5.0))
            other.cancel_goal()
            other.wait_for_result(rospy.Duration(5.0))
    finally:
        processes.stop(sim)
    for name, values in (('goal -> first feedback, idle server', idle),
                         ('goal -> first feedback, preempting an active goal', preempting)):
        rows.append((name, '%.1f ms median' % statistics.median(values), 'max %.1f ms' % max(values),
                     '< 20 ms median'))


def contact_delays(namespace, repeats=6):
    """Wall ms from a charger_contact change to the status it asks for on battery_status, ``repeats`` times."""
    contact = rospy.Publisher(namespace + '/charger_contact', Bool, queue_size=1, latch=True)
    arrivals = Arrivals(namespace + '/battery_status')
    delays = []
    try:
        wait_until(lambda: contact.get_num_connections() > 0 and arrivals.count() > 0, 30.0, 'the robot')
        for index in range(repeats):
            connected = index % 2 == 0
            wanted = (BatteryState.POWER_SUPPLY_STATUS_CHARGING if connected
                      else BatteryState.POWER_SUPPLY_STATUS_DISCHARGING)
            start, sent = arrivals.count(), time.monotonic()
            contact.publish(Bool(data=connected))
            wait_until(lambda: any(m.power_supply_status == wanted for _, m in arrivals.since(start)), 10.0,
                       'the status change')
            arrived = next(t for t, m in arrivals.since(start) if m.power_supply_status == wanted)
            delays.append(1000.0 * (arrived - sent))
            time.sleep(0.3 + random.random() * 0.7)   # land at different points of the publisher's period
    finally:
        contact.unregister()
        arrivals.close()
    return delays


def measure_contact(processes, rows, repeats=6):
    for rate_hz in (1.0, 0.2):
        ns = 'contact%d' % (rate_hz * 10)
        sim = launch(processes, 'sim.launch', ns, rate=rate_hz, initial_percentage=50)
        try:
            delays = contact_delays('/' + ns, repeats)
        finally:
            processes.stop(sim)
        rows.append(('contact -> status on battery_status at %g Hz' % rate_hz,
                     '%.0f ms median' % statistics.median(delays), 'max %.0f ms' % max(delays), '< 1 s'))


def measure_cost_and_start(processes, rows):
    starts = []
    for attempt in range(3):
        ns = 'start%d' % attempt
        arrivals = Arrivals('/%s/battery_status' % ns)
        started = time.monotonic()
        sim = launch(processes, 'sim.launch', ns)
        try:
            wait_until(lambda: arrivals.count() > 0, 30.0, 'the first battery_status')
            starts.append(time.monotonic() - started)
            if attempt == 0:
                names = ['/%s/BatterySimServer' % ns, '/%s/battery_state_pub' % ns]
                pids = process_ids(names)
                time.sleep(5.0)
                cpu = cpu_percent(list(pids.values()), 30.0)
                for name in names:
                    rows.append(('%s at the defaults' % name.split('/')[-1], '%.2f %% CPU' % cpu[pids[name]],
                                 '%.0f MB RSS' % rss_mb(pids[name]), '< 2 % and < 60 MB'))
        finally:
            arrivals.close()
            processes.stop(sim)
    rows.append(('sim.launch -> first battery_status (master running)', '%.2f s median' % statistics.median(starts),
                 'max %.2f s' % max(starts), '< 3 s'))


def one_hour_plan(charge_to_percentage):
    """A task allocator's question: an hour of driving, turning and a payload, in 60 one-minute segments."""
    return PredictRequest(duration_s=[60.0] * 60, power_w=[5.0 * (k % 3) for k in range(60)],
                          speed_mps=[0.22 * (k % 2) for k in range(60)], turn_radps=[0.5 * (k % 4) for k in range(60)],
                          charge_to_percentage=charge_to_percentage)


def measure_prediction(processes, rows, calls=10):
    """Wall ms per battery_simulator/predict call on a running server, median of ``calls`` (after one)."""
    sim = launch(processes, 'sim.launch', 'predict')
    try:
        rospy.wait_for_service('/predict/battery_simulator/predict', 30.0)
        predict = rospy.ServiceProxy('/predict/battery_simulator/predict', Predict, persistent=True)
        figures = []
        for charge_to_percentage in (float('nan'), 100.0):
            request = one_hour_plan(charge_to_percentage)
            assert predict(request).success
            times = []
            for _ in range(calls):
                sent = time.perf_counter()
                predict(request)
                times.append(1000.0 * (time.perf_counter() - sent))
            figures.append(times)
        predict.close()
    finally:
        processes.stop(sim)
    (plan, charged) = figures
    rows.append(('predict: a one-hour plan (60 segments), median of %d calls' % calls,
                 '%.1f ms median' % statistics.median(plan),
                 'max %.1f ms; with a charge to 100 %%: %.1f ms median' % (max(plan), statistics.median(charged)),
                 '<= 50 ms'))


def threads(pid):
    with open('/proc/%d/status' % pid) as stream:
        return next(int(line.split()[1]) for line in stream if line.startswith('Threads:'))


def open_files(pid):
    return len(os.listdir('/proc/%d/fd' % pid))


def fleet_host_pids(hosts):
    names = ['/battery_fleet'] + ['/battery_fleet_%d' % k for k in range(1, hosts)]
    return list(process_ids(names).values())


#: (n, hosts, update_rate or None for fleet.launch's, targets: first battery_status, CPU, memory)
FLEET_CASES = ((1, 1, None, '', '', ''), (10, 1, None, '', '', ''),
               (100, 1, None, '<= 10 s', '<= 8 %', '<= 100 MB'),
               (1000, 4, None, '<= 30 s', '<= 40 %', '<= 500 MB'), (1000, 4, 10, '', '', ''))


def measure_fleet(processes, rows, master=None):
    """fleet.launch at N = 1, 10, 100 (one host) and 1000 (hosts:=4), with every battery_status subscribed."""
    fleet_cases(processes, rows, master, FLEET_CASES)


def measure_fleet1000(processes, rows, master=None):
    """fleet.launch n:=1000 hosts:=4 alone (the fleet row of README), with every battery_status subscribed."""
    fleet_cases(processes, rows, master, [case for case in FLEET_CASES if case[0] == 1000 and not case[2]])


def fleet_cases(processes, rows, master, cases):
    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    resource.setrlimit(resource.RLIMIT_NOFILE, (hard, hard))   # this process subscribes to every robot
    for n, hosts, update_rate, first_target, cpu_target, memory_target in cases:
        arrivals = [Arrivals('/robot%d/battery_status' % i) for i in range(n)]
        started = time.monotonic()
        fleet = processes.start(['prlimit', '--nofile=1024:%d' % hard, 'roslaunch', 'battery_simulator',
                                 'fleet.launch', 'n:=%d' % n, 'hosts:=%d' % hosts]
                                + (['update_rate:=%g' % update_rate] if update_rate else []))
        try:
            wait_until(lambda: all(a.count() > 0 for a in arrivals), 120.0, 'every robot publishing')
            first_s = max(a.items[0][0] for a in arrivals) - started
            pids = fleet_host_pids(hosts)
            time.sleep(5.0)
            marks = [a.count() for a in arrivals]
            cpu = cpu_percent(pids + ([master.pid] if master else []), 30.0)
            master_cpu = cpu.pop(master.pid) if master else float('nan')
            rates, stamped_rates = [], []   # as received here, and as the hosts stamped them (sent)
            for arrival, mark in zip(arrivals, marks):
                items = arrival.since(mark)
                times = [t for t, _ in items]
                rates.append((len(times) - 1) / (times[-1] - times[0]))
                stamps = [msg.header.stamp.to_sec() for _, msg in items]
                stamped_rates.append((len(stamps) - 1) / (stamps[-1] - stamps[0]))
            feedback_ms, contact_ms = (robot_latencies('/robot%d' % (n // 2)) if n >= 100 and not update_rate
                                       else (None, None))
            memory = sum(rss_mb(pid) for pid in pids)
            row_threads = sum(threads(pid) for pid in pids)
            files = sum(open_files(pid) for pid in pids)
        finally:
            for arrival in arrivals:
                arrival.close()
            processes.stop(fleet)
        name = 'fleet.launch n:=%d hosts:=%d%s' % (n, hosts, ' update_rate:=%g' % update_rate if update_rate else '')
        rows.append((name + ': processes, threads, open files', '%d, %d, %d' % (hosts, row_threads, files),
                     '%.1f threads, %.1f files per robot' % (row_threads / n, files / n), ''))
        rows.append((name + ': RSS, CPU (every battery_status subscribed)', '%.0f MB, %.1f %% of a core'
                     % (memory, sum(cpu.values())), 'master %.2f %% of a core' % master_cpu,
                     ('%s, %s, master <= 5 %%' % (memory_target, cpu_target)) if cpu_target else ''))
        rows.append((name + ': launch -> every first battery_status', '%.1f s' % first_s,
                     'rates %.4f .. %.4f Hz received, %.4f .. %.4f Hz stamped (1 Hz)' % (
                         min(rates), max(rates), min(stamped_rates), max(stamped_rates)),
                     ('%s, rates within 1 %%' % first_target) if first_target else ''))
        if feedback_ms is not None:
            rows.append((name + ': robot %d preempting goal -> first feedback' % (n // 2),
                         '%.1f ms median' % statistics.median(feedback_ms),
                         'contact -> status %.0f ms median' % statistics.median(contact_ms), '< 20 ms, < 1 s'))
    resource.setrlimit(resource.RLIMIT_NOFILE, (soft, hard))


def robot_latencies(namespace, repeats=10):
    """(preempting goal -> first feedback ms, contact -> status ms) for one robot of a running fleet."""
    client = actionlib.SimpleActionClient(namespace + '/battery_simulator', battery_simAction)
    other = actionlib.SimpleActionClient(namespace + '/battery_simulator', battery_simAction)
    assert client.wait_for_server(rospy.Duration(30.0)) and other.wait_for_server(rospy.Duration(30.0))
    feedback = []
    for index in range(repeats):
        charge = bool(index % 2)
        first_feedback_ms(client, charge)
        feedback.append(first_feedback_ms(other, not charge))   # preempts client's goal
        other.cancel_goal()
        other.wait_for_result(rospy.Duration(5.0))
    return feedback, contact_delays(namespace)


def page_in_chromium(url):
    """A headless Chromium (Selenium) showing ``url``, as a person would leave it open."""
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service
    options = webdriver.ChromeOptions()
    for argument in ('--headless=new', '--no-sandbox', '--disable-gpu', '--window-size=1280,800'):
        options.add_argument(argument)
    driver = webdriver.Chrome(options=options, service=Service('/usr/bin/chromedriver'))
    driver.get(url)
    return driver


def measure_dashboard(processes, rows, n=100):
    """battery_dashboard with fleet.launch n:=100 at 1 Hz and the overview open in headless Chromium."""
    port = free_port()
    fleet = launch(processes, 'fleet.launch', n=n)
    dashboard, driver = None, None
    try:
        master = rosgraph.Master('/graph_benchmark')
        last_topic = '/robot%d/battery_status' % (n - 1)
        wait_until(lambda: any(topic == last_topic for topic, _ in master.getPublishedTopics('/')), 120.0,
                   'the fleet')   # two roslaunch starting at once race for /run_id: one after the other
        dashboard = launch(processes, 'dashboard.launch', port=port)
        url = 'http://127.0.0.1:%d/' % port
        wait_until(lambda: time.sleep(0.2) or dashboard_batteries(port) == n, 120.0,
                   'the dashboard showing %d batteries' % n)
        driver = page_in_chromium(url)
        wait_until(lambda: driver.execute_script("return document.querySelectorAll('[data-battery]').length") == n,
                   60.0, '%d batteries on the page' % n)
        pids = process_ids(['/battery_dashboard', '/battery_fleet'])
        time.sleep(5.0)
        cpu = cpu_percent(list(pids.values()), 20.0)
        fresh = driver.execute_script("return document.querySelectorAll('[data-battery]:not(.stale)').length")
        memory = rss_mb(pids['/battery_dashboard'])
    finally:
        if driver is not None:
            driver.quit()
        if dashboard is not None:
            processes.stop(dashboard)
        processes.stop(fleet)
    rows.append(('battery_dashboard: %d batteries at 1 Hz, the page open (20 s)' % n,
                 '%.1f %% of a core' % cpu[pids['/battery_dashboard']],
                 '%.0f MB RSS, %d of %d fresh on the page; fleet host %.1f %%'
                 % (memory, fresh, n, cpu[pids['/battery_fleet']]), '<= 10 %'))


def dashboard_batteries(port):
    try:
        connection = http.client.HTTPConnection('127.0.0.1', port, timeout=5.0)
        connection.request('GET', '/api/batteries')
        return len(json.loads(connection.getresponse().read())['batteries'])
    except (OSError, ValueError):
        return -1


#: a busy loop: one core's worth of other work beside a measurement (``--hogs=N``)
HOG = 'while True:\n    pass'


def run(sections, hogs=0):
    """Start a master (and ``hogs`` busy loops beside the graph), run the named sections, return the table rows."""
    port = free_port()
    os.environ['ROS_MASTER_URI'] = 'http://127.0.0.1:%d' % port
    processes = Processes()
    master = processes.start(['rosmaster', '--core', '-p', str(port)])
    for _ in range(hogs):
        processes.start([sys.executable, '-c', HOG])
    rows = []
    try:
        wait_until(lambda: rosgraph.Master('/graph_benchmark').is_online(), 30.0, 'the master')
        rospy.init_node('graph_benchmark', disable_signals=True)
        for section in sections:
            if section in (measure_fleet, measure_fleet1000):
                section(processes, rows, master)
            else:
                section(processes, rows)
    finally:
        processes.stop_all()   # the master last: it was started first
    return rows


SECTIONS = (measure_goals, measure_contact, measure_cost_and_start, measure_prediction, measure_rates, measure_fleet,
            measure_dashboard, measure_fleet1000)
#: sections run only when named (``tools/benchmark.sh fleet1000``): a part of another one
ON_REQUEST = (measure_fleet1000,)
