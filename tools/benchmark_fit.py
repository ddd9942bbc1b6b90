#!/usr/bin/python3
"""battery_fit's speed (issue 36): a one-hour log at 1 Hz within 30 s, a 24-hour log within 5 min, on one core.

    /usr/bin/python3 tools/benchmark_fit.py [--hours 1 24]

Each log is made with this simulator (test/unit/fit_logs.py: the core model, cmd_vel at 10 Hz, BatteryState
at 1 Hz with noise), written as a CSV, and fitted by battery_fit in this process (reading, fit, replay
for the figures, config); the seconds are printed beside the limit and the reference run below.
"""
import argparse
import io
import os
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path[:0] = [os.path.join(HERE, '..', 'src'), os.path.join(HERE, '..', 'test', 'unit')]

import fit_logs  # noqa: E402
from battery_simulator.cli import fit as fit_cli  # noqa: E402

LIMITS_S = {1.0: 30.0, 24.0: 300.0}
#: the reference run (CPU s): Debian 12, 2 shared cores, one used (2026-11-26, branch fit)
REFERENCE_S = {1.0: 1.6, 24.0: 9.9}


def run(hours, directory):
    params = fit_logs.robot_params()
    samples, commands = fit_logs.simulate(params, duration_s=3600.0 * hours, seed=11, charge_at_s=None)
    path = os.path.join(directory, 'log_%gh.csv' % hours)
    fit_logs.write_csv(path, samples, commands)
    args = fit_cli.parse_arguments([path, '-o', os.path.join(directory, 'fit_%gh.yaml' % hours)])
    start = time.process_time()
    wall = time.monotonic()
    report = io.StringIO()
    fit_cli.run(args, stdout=report)
    held = [line for line in report.getvalue().splitlines() if 'held-out part:' in line][0].split()[2]
    return time.process_time() - start, time.monotonic() - wall, len(samples), held


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--hours', type=float, nargs='+', default=[1.0, 24.0])
    args = parser.parse_args()
    print('%-8s %8s %10s %10s %10s %10s  %s' % ('log', 'samples', 'cpu s', 'wall s', 'limit s', 'reference',
                                                'held-out mV/cell'))
    failed = False
    with tempfile.TemporaryDirectory() as directory:
        for hours in args.hours:
            cpu, wall, count, held = run(hours, directory)
            limit = LIMITS_S.get(hours)
            failed |= limit is not None and cpu > limit
            print('%-8s %8d %10.1f %10.1f %10s %10s  %s' % ('%g h' % hours, count, cpu, wall,
                                                         '%g' % limit if limit else '-',
                                                         '%g' % REFERENCE_S[hours] if hours in REFERENCE_S else '-',
                                                         held))
    sys.exit(1 if failed else 0)


if __name__ == '__main__':
    main()
