#!/usr/bin/python3
"""A predict storm on one robot of a fleet, and what its neighbours feel (figures, no pass/fail).

    source build/devel/setup.bash
    /usr/bin/python3 tools/predict_storm.py [--threads 8] [--segments 3600 100000] [--toggles 16]

Starts its own master on a free port and ``fleet.launch n:=3`` (one host,
robots robot0..robot2, the defaults: update_rate 2, battery_status at 1 Hz),
then, without a storm and during each storm (``--threads`` clients in another
process, each sending robot0 a plan of N one-second segments of different
loads as fast as it is answered):

  - robot1's charger_contact -> CHARGING / DISCHARGING on its battery_status
    (wall ms, ``--toggles`` changes, median and max);
  - the longest gap between robot2's battery_status messages (s; 1 s at 1 Hz);
  - robot1's own prediction of a one-hour plan of 3600 different one-second
    loads (ms, median and p90): a neighbour's service;
  - the storm's answers (ok / busy / other) and the CPU of the host and of
    its prediction workers.

Issue 28 measured on the code before the prediction workers: contact ->
CHARGING from 4 ms to a median of 962 ms with 8 threads of 3600 segments.
The host's processes are ended by pid (SIGINT, then SIGKILL).
"""
import argparse
import json
import math
import os
import random
import signal
import statistics
import subprocess
import sys
import threading
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import rosgraph  # noqa: E402
import rospy  # noqa: E402
from sensor_msgs.msg import BatteryState  # noqa: E402
from std_msgs.msg import Bool  # noqa: E402

from battery_simulator.srv import Predict, PredictRequest  # noqa: E402
from graph_benchmark import Arrivals, Processes, cpu_seconds, free_port, launch, process_ids, wait_until  # noqa: E402

PREDICT = '/%s/battery_simulator/predict'


def plan(segments, seed):
    """``segments`` one-second segments of different loads (power, speed, turn), no charge."""
    rng = random.Random(seed)
    return PredictRequest(duration_s=[1.0] * segments, power_w=[rng.uniform(0.0, 10.0) for _ in range(segments)],
                          speed_mps=[rng.uniform(-0.3, 0.3) for _ in range(segments)],
                          turn_radps=[rng.uniform(-1.0, 1.0) for _ in range(segments)],
                          charge_to_percentage=math.nan)


# -- the storm (a process of its own: its clients' work is not the measurer's) ---------

def storm(service, threads, segments):
    """Ask ``service`` from ``threads`` threads until SIGINT/SIGTERM; print the answers' counts as JSON."""
    rospy.init_node('predict_storm', anonymous=True, disable_signals=True)
    stop = threading.Event()
    for number in (signal.SIGINT, signal.SIGTERM):
        signal.signal(number, lambda *_: stop.set())
    counts = {'ok': 0, 'busy': 0, 'other': 0}
    lock = threading.Lock()

    def client(seed):
        request = plan(segments, seed)
        proxy = rospy.ServiceProxy(service, Predict, persistent=True)
        while not stop.is_set():
            try:
                response = proxy(request)
            except (rospy.ServiceException, OSError) as error:
                kind, text = 'other', str(error)
                proxy = rospy.ServiceProxy(service, Predict, persistent=True)
            else:
                text = response.message
                kind = 'ok' if response.success else 'busy' if text.startswith('busy') else 'other'
            with lock:
                counts[kind] += 1
                if kind != 'ok':
                    counts.setdefault('first_' + kind, text[:200])
        proxy.close()

    rospy.wait_for_service(service, 30.0)
    workers = [threading.Thread(target=client, args=(seed,), daemon=True) for seed in range(threads)]
    started = time.monotonic()
    for worker in workers:
        worker.start()
    print('storming', flush=True)
    stop.wait()
    for worker in workers:
        worker.join(timeout=30.0)
    counts['seconds'] = time.monotonic() - started
    print(json.dumps(counts), flush=True)


# -- the measurements -----------------------------------------------------------------

def contact_delays(toggles):
    """robot1's charger_contact -> the status it asks for on battery_status, wall ms, ``toggles`` times."""
    contact = rospy.Publisher('/robot1/charger_contact', Bool, queue_size=1, latch=True)
    arrivals = Arrivals('/robot1/battery_status')
    delays = []
    try:
        wait_until(lambda: contact.get_num_connections() > 0 and arrivals.count() > 0, 30.0, 'robot1')
        for index in range(toggles):
            connected = index % 2 == 0
            wanted = (BatteryState.POWER_SUPPLY_STATUS_CHARGING if connected
                      else BatteryState.POWER_SUPPLY_STATUS_DISCHARGING)
            start, sent = arrivals.count(), time.monotonic()
            contact.publish(Bool(data=connected))
            wait_until(lambda: any(m.power_supply_status == wanted for _, m in arrivals.since(start)), 30.0,
                       'the status change')
            arrived = next(t for t, m in arrivals.since(start) if m.power_supply_status == wanted)
            delays.append(1000.0 * (arrived - sent))
            time.sleep(0.2 + random.random() * 0.3)   # land at different points of the periods
    finally:
        contact.unregister()
        arrivals.close()
    return delays


def neighbour_predictions(calls):
    """robot1's answers to a one-hour plan of 3600 different one-second loads, wall ms (persistent proxy)."""
    proxy = rospy.ServiceProxy(PREDICT % 'robot1', Predict, persistent=True)
    request = plan(3600, 1234)
    times, answers = [], []
    try:
        for _ in range(calls):
            sent = time.perf_counter()
            response = proxy(request)
            times.append(1000.0 * (time.perf_counter() - sent))
            answers.append(response.success)
    finally:
        proxy.close()
    return times, answers


def children(pid):
    """The process ids whose parent is ``pid``."""
    found = []
    for entry in os.listdir('/proc'):
        if entry.isdigit():
            try:
                with open('/proc/%s/stat' % entry) as stream:
                    if int(stream.read().rsplit(')', 1)[1].split()[1]) == pid:
                        found.append(int(entry))
            except (OSError, IndexError, ValueError):
                pass
    return found


def cpu_total(pids):
    total = 0.0
    for pid in pids:
        try:
            total += cpu_seconds(pid)
        except OSError:
            pass
    return total


def phase(name, host_pid, toggles, calls):
    """One row of figures, measured now."""
    gaps = Arrivals('/robot2/battery_status')
    wait_until(lambda: gaps.count() >= 2, 30.0, 'robot2')
    workers = children(host_pid)
    cpu_before, wall_before = (cpu_total([host_pid]), cpu_total(workers)), time.monotonic()
    delays = contact_delays(toggles)
    times, answers = neighbour_predictions(calls)
    seconds = time.monotonic() - wall_before
    workers = sorted(set(workers) | set(children(host_pid)))
    host_cpu = 100.0 * (cpu_total([host_pid]) - cpu_before[0]) / seconds
    worker_cpu = 100.0 * (cpu_total(workers) - cpu_before[1]) / seconds
    stamps = [t for t, _ in gaps.since(0)]
    gaps.close()
    times.sort()
    return {'phase': name, 'contact_median_ms': statistics.median(delays), 'contact_max_ms': max(delays),
            'robot2_max_gap_s': max(b - a for a, b in zip(stamps, stamps[1:])),
            'robot1_predict_median_ms': statistics.median(times), 'robot1_predict_p90_ms': times[int(0.9 * len(times))],
            'robot1_predict_ok': sum(answers), 'robot1_predict_calls': len(answers),
            'host_cpu_pct': host_cpu, 'worker_cpu_pct': worker_cpu, 'workers': len(workers), 'seconds': seconds}


def run(args):
    port = free_port()
    os.environ['ROS_MASTER_URI'] = 'http://127.0.0.1:%d' % port
    processes = Processes()
    processes.start(['rosmaster', '--core', '-p', str(port)])
    rows = []
    try:
        wait_until(lambda: rosgraph.Master('/predict_storm').is_online(), 30.0, 'the master')
        rospy.init_node('predict_storm_measure', disable_signals=True)
        fleet = launch(processes, 'fleet.launch', n=3)
        for robot in ('robot0', 'robot1'):
            rospy.wait_for_service(PREDICT % robot, 60.0)
        host_pid = process_ids(['/battery_fleet'])['/battery_fleet']
        time.sleep(2.0)   # the host settles (its workers start)
        rows.append(phase('no storm', host_pid, args.toggles, args.calls))
        for segments in args.segments:
            command = [sys.executable, __file__, '--storm', PREDICT % 'robot0', '--threads', str(args.threads),
                       '--segments', str(segments)]
            stormer = subprocess.Popen(command, stdout=subprocess.PIPE, text=True, start_new_session=True)
            try:
                assert stormer.stdout.readline().strip() == 'storming'
                time.sleep(2.0)   # the storm builds up
                row = phase('%d threads x %d segments' % (args.threads, segments), host_pid, args.toggles,
                            args.calls)
            finally:
                os.killpg(stormer.pid, signal.SIGINT)
                try:
                    out, _ = stormer.communicate(timeout=60.0)
                except subprocess.TimeoutExpired:
                    os.killpg(stormer.pid, signal.SIGKILL)
                    out, _ = stormer.communicate()
            counts = json.loads(out.strip().splitlines()[-1]) if out.strip() else {}
            row.update(storm=counts)
            rows.append(row)
        processes.stop(fleet)
    finally:
        processes.stop_all()   # the master last: it was started first
    return rows


def main():
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--threads', type=int, default=8)
    parser.add_argument('--segments', type=int, nargs='+', default=[3600, 100000])
    parser.add_argument('--toggles', type=int, default=16)
    parser.add_argument('--calls', type=int, default=20, help="robot1's one-hour predictions per phase")
    parser.add_argument('--storm', help=argparse.SUPPRESS)
    parser.add_argument('--json', action='store_true', help='print the rows as JSON')
    args = parser.parse_args()
    if args.storm:
        storm(args.storm, args.threads, args.segments[0])
        return
    rows = run(args)
    if args.json:
        print(json.dumps(rows, indent=1))
        return
    print('| phase | robot1 contact -> status (median / max) | robot2 longest battery_status gap | robot1 one-hour '
          'predict (median / p90, ok) | host CPU | workers CPU | storm answers (ok / busy / other, per s) |')
    print('| --- | --- | --- | --- | --- | --- | --- |')
    for row in rows:
        storm_counts = row.get('storm')
        answers = ('%d / %d / %d, %.1f ok/s' % (storm_counts['ok'], storm_counts['busy'], storm_counts['other'],
                                                storm_counts['ok'] / storm_counts['seconds'])
                   if storm_counts else '-')
        print('| %s | %.0f / %.0f ms | %.2f s | %.0f / %.0f ms, %d/%d | %.0f %% | %.0f %% (%d) | %s |' % (
            row['phase'], row['contact_median_ms'], row['contact_max_ms'], row['robot2_max_gap_s'],
            row['robot1_predict_median_ms'], row['robot1_predict_p90_ms'], row['robot1_predict_ok'],
            row['robot1_predict_calls'], row['host_cpu_pct'], row['worker_cpu_pct'], row['workers'], answers))


if __name__ == '__main__':
    main()
