#!/usr/bin/python3
"""What the learning gauge costs (issue 43): measured figures beside a reference measured in the same run.

    /usr/bin/python3 tools/gauge_benchmark.py [--fleet 1000] [--rounds 30]

1. One model step of the default pack (lg_hg2_3s1p) as a battery node steps it (10 Hz at time_scale 22:
   2.2 s a step), through whole discharges at 1.5 A and charges (so the learning gauge's forward runs for
   its remaining capacity, its rests and its tapers are all in): an ideal gauge, a coulomb counter (the
   reference) and the learning gauge. Target: the learning gauge's step at most 1.3x the counter's.
2. A fleet of ``--fleet`` batteries (core/battery.py's Battery.update, what both fleet hosts call for each
   robot at each tick) with the learning gauge beside the same fleet without it: with the default gauge
   (ideal: no gauge at all), and with a coulomb counter. This is the model's share of a fleet's cost alone,
   ticked at 10 Hz: the issue's figure (a fleet of 1000 within 10 % of its cost without the gauge) is the
   fleet host's CPU, measured by ``tools/ros2.sh python3 tools/ros2_benchmark.py gauge 1000`` (1 Hz updates,
   every battery_status published: there the gauge's step is about 2 us a robot a second of the host's 130).
Each figure is the CPU time of this process (time.process_time: on a machine shared with other work, wall
time measures the others too), the median of the runs, the runs of the three gauges interleaved.
"""
import argparse
import importlib.util
import statistics
import sys
import time
from pathlib import Path

if importlib.util.find_spec('battery_simulator') is None:   # not sourced: the checkout's src/
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / 'src'))

from battery_simulator.core.battery import Battery  # noqa: E402
from battery_simulator.core.battery_states import Mode, Status  # noqa: E402
from battery_simulator.core.config_files import from_mapping  # noqa: E402
from battery_simulator.core.pack import make_model  # noqa: E402

GAUGES = {'ideal': {'model': 'ideal'},
          'counter': {'model': 'coulomb_counter', 'current_offset_a': 0.01, 'capacity_error': 0.05},
          'learning': {'model': 'learning', 'current_offset_a': 0.01, 'capacity_error': 0.05}}
STEP_S = 2.2
STEPS = 40_000     # about a discharge and a charge at 1.5 A with 2.2 s steps, twice
REPEATS = 5
FLEET_REPEATS = 3
#: fleet rounds of 22 s of battery time before the measured ones (a running fleet's steady state, past
#: every gauge's first look at its load)
WARM_UP_ROUNDS = 10


def params(gauge):
    return from_mapping({'preset': 'lg_hg2_3s1p', 'gauge': GAUGES[gauge]})


def step_us(gauge, steps=STEPS):
    """Microseconds per model step over discharges to the cut-off and charges to Full, alternating."""
    model = make_model(params(gauge), 1.0, Mode.DISCHARGE)
    step = model.step
    start = time.process_time()
    for _ in range(steps):
        step(STEP_S)
        status = model.status
        if status is Status.EMPTY:
            model.set_mode(Mode.CHARGE)
        elif status is Status.FULL:
            model.set_mode(Mode.DISCHARGE)
    return (time.process_time() - start) / steps * 1e6


class Clock:
    def __init__(self):
        self.now = 0.0

    def __call__(self):
        return self.now


def fleet_ms(gauge, size, rounds):
    """Milliseconds per round of ``size`` batteries' updates (0.1 s of wall time at time_scale 22 each), after
    WARM_UP_ROUNDS."""
    clock = Clock()
    fleet = [Battery(params(gauge), 20.0 + 60.0 * index / size, clock=clock, time_scale=22.0)
             for index in range(size)]
    for _ in range(WARM_UP_ROUNDS):   # past the start (every gauge's first look at its load)
        clock.now += 1.0
        for battery in fleet:
            battery.update()
    start = time.process_time()
    for _ in range(rounds):
        clock.now += 0.1
        for battery in fleet:
            battery.update()
    return (time.process_time() - start) / rounds * 1e3


def medians(measure, *args, repeats=REPEATS):
    runs = {gauge: [] for gauge in GAUGES}
    for _ in range(repeats):
        for gauge in GAUGES:   # interleaved: the machine's load falls on all three alike
            runs[gauge].append(measure(gauge, *args))
    return {gauge: statistics.median(values) for gauge, values in runs.items()}


def main(argv=None):
    parser = argparse.ArgumentParser(prog='gauge_benchmark.py', description=__doc__.splitlines()[0])
    parser.add_argument('--fleet', type=int, default=1000, help='batteries in the fleet (default 1000)')
    parser.add_argument('--rounds', type=int, default=60, help='fleet rounds per run (default 60: 132 s of battery)')
    args = parser.parse_args(argv)
    steps = medians(step_us)
    print('One step of lg_hg2_3s1p at 2.2 s (10 Hz, time_scale 22), discharges and charges, median of %d:'
          % REPEATS)
    for gauge, us in steps.items():
        print('  %-9s %6.2f us   %.2fx the counter' % (gauge, us, us / steps['counter']))
    print('  target: learning <= 1.3x the counter: %s' % ('met' if steps['learning'] <= 1.3 * steps['counter']
                                                         else 'NOT met'))
    fleets = medians(fleet_ms, args.fleet, args.rounds, repeats=FLEET_REPEATS)
    print('A fleet of %d (Battery.update each, one round of %d after %d rounds of 22 s), median of %d:'
          % (args.fleet, args.rounds, WARM_UP_ROUNDS, FLEET_REPEATS))
    for gauge, ms in fleets.items():
        print('  %-9s %7.1f ms   %.3fx the counter, %.3fx ideal' % (gauge, ms, ms / fleets['counter'],
                                                                   ms / fleets['ideal']))
    print('  (the model alone; the fleet host with and without the gauge, the issue\'s "within 10 %%": '
          'tools/ros2.sh python3 tools/ros2_benchmark.py gauge 1000)')


if __name__ == '__main__':
    main()
