#!/usr/bin/python3
"""Speed figures of the battery model and of the running ROS graph (tables of
measured numbers beside their targets, no pass/fail).

    /usr/bin/python3 tools/benchmark.py            # the model (no ROS needed)
    tools/benchmark.sh                             # the model and the ROS graph (builds, sources devel)
    tools/benchmark.sh fleet1000 [--hogs=2]        # ROS 1's fleet of 1000 alone (beside 2 busy loops)

Model target: one step < 5 us in CPython (issue 25: two RC pairs, resistance
tables and the OCV hysteresis within that), so a day of battery life at 10 Hz
(864,000 steps) replays in seconds. Graph targets: see tools/graph_benchmark.py.
"""
import importlib.util
import os
import statistics
import sys
import time
from pathlib import Path

if importlib.util.find_spec('battery_simulator') is None:   # not sourced: the checkout's src/
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / 'src'))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from battery_simulator.core.battery_states import Mode  # noqa: E402
from battery_simulator.core.config_files import preset  # noqa: E402
from battery_simulator.core.pack import make_model  # noqa: E402
from battery_simulator.core.replay import replay  # noqa: E402

STEPS = 200_000
REPEATS = 5


def per_step_us(mode, soc, preset_name='lg_hg2_3s1p', steps=STEPS, **step_args):
    """Median microseconds per step over REPEATS runs of ``steps`` steps (``soc`` 'taper': in the CV
    phase, the charge current at 60 % of the charger's)."""
    runs = []
    for _ in range(REPEATS):
        if soc == 'taper':
            model = make_model(preset(preset_name), state_of_charge=0.9, mode=Mode.CHARGE)
            while not 0.0 < model.current_a <= 0.6 * model.params.charge_current_a:
                model.step(10.0)
        else:
            model = make_model(preset(preset_name), state_of_charge=soc, mode=mode)
        model.set_extra_load('motion', current_a=0.0)
        step = model.step
        start = time.perf_counter()
        for _ in range(steps):
            step(1e-4, **step_args)  # tiny dt: the state stays in the regime being measured
        runs.append((time.perf_counter() - start) / steps * 1e6)
    return statistics.median(runs)


def day_replay_s():
    """Wall seconds to replay 24 h at 10 Hz (864,000 steps) through replay()."""
    profile = [(100.0 * k, 'current', -0.5) for k in range(864)] + [(86400.0, 'current', 0.0)]
    start = time.perf_counter()
    rows = list(replay(preset('lg_hg2_7s4p'), profile, max_step_s=0.1))
    assert len(rows) == len(profile)
    return time.perf_counter() - start


def print_table(title, header, rows):
    widths = [max(len(str(row[i])) for row in [header] + rows) for i in range(len(header))]
    print('\n' + title)
    print('  '.join('%-*s' % (w, h) for w, h in zip(widths, header)))
    print('-' * (sum(widths) + 2 * (len(widths) - 1)))
    for row in rows:
        print('  '.join('%-*s' % (w, c) for w, c in zip(widths, row)))


def main():
    if '--graph' in sys.argv[1:]:
        import graph_benchmark   # needs ROS: the devel space sourced
        names = [a for a in sys.argv[1:] if not a.startswith('--')]   # e.g. rates fleet: only those sections
        hogs = int(next((a.split('=', 1)[1] for a in sys.argv[1:] if a.startswith('--hogs=')), 0))
        rows = graph_benchmark.run([s for s in graph_benchmark.SECTIONS
                                    if s.__name__[8:] in names or not names and s not in graph_benchmark.ON_REQUEST],
                                   hogs)
        print_table('The running ROS graph (%d cores%s)' % (
            os.cpu_count(), ', beside %d CPU hogs (busy loops)' % hogs if hogs else ''),
                    ('measurement', 'figure', 'beside it', 'target'), rows)
    rows = [
        ('step, discharging (mode load)', '%.2f us' % per_step_us(Mode.DISCHARGE, 0.8)),
        ('step, CC charging', '%.2f us' % per_step_us(Mode.CHARGE, 0.3)),
        ('step, CV charging (taper)', '%.2f us' % per_step_us(Mode.CHARGE, 0.995)),
        ('step, replayed current', '%.2f us' % per_step_us(Mode.IDLE, 0.5, current_a=-2.0)),
        ('24 h at 10 Hz replay (864,000 steps)', '%.2f s' % day_replay_s()),
    ]
    print_table('The battery model (CPython %d.%d)' % sys.version_info[:2], ('measurement', 'figure', 'target'),
                [(name, figure, '< 5 us' if figure.endswith('us') else 'seconds') for name, figure in rows])
    rows = []
    for name, mode, soc in (('discharging', Mode.DISCHARGE, 0.8), ('CC charging', Mode.CHARGE, 0.3),
                            ('CV charging (taper)', Mode.CHARGE, 'taper')):
        lumped = per_step_us(mode, soc, 'lg_hg2_7s4p', steps=STEPS // 10)
        aged = per_step_us(mode, soc, 'lg_hg2_7s4p_aged', steps=STEPS // 10)
        rows.append(('step, 7-group pack %s' % name, '%.2f us' % aged, '%.2f us' % lumped,
                     '%.1f x' % (aged / lumped), '<= 7 x (Part 5)'))
    print_table('A pack of 7 differing groups (lg_hg2_7s4p_aged: balancing, coulomb counter) beside the lumped '
                'lg_hg2_7s4p in the same phase', ('measurement', 'figure', 'lumped step', 'ratio', 'target'), rows)


if __name__ == '__main__':
    main()
