#!/usr/bin/env python3
"""A docking study a fleet manager can rerun: "dock at 25 %" against three fuel gauges (issue 43 item 5).

    tools/gauge_study.py [--days 20] [--packs 6] [--seed 1] [--dock-at 25] [--step 30]

Each pack (drawn from ``--seed``: its age, 0-600 cycles of lg_hg2_3s1p; its ambient temperature, 0-35 degC;
its gauge's sensor offset and gain error and a start error of up to 3 points; the gauge believes the new
pack's capacity) lives ``--days`` simulated days three times, once with each gauge: ``ideal`` (the robot
reads the truth), ``counter`` (a coulomb counter with those errors, recalibrating at full and empty) and
``learning`` (Part 9's learning gauge with the same errors). The day is the same for the three (one random
stream per pack): the robot patrols at a load drawn every 10 min (0.8-2.2 A), waits for a task now and then
(45-90 min asleep at 0.02 A: a rest to a gauge, below C/20 and settled), heads for the dock when the
percentage it reads falls below ``--dock-at`` (5 min of driving at 2 A), charges until the charger ends, and
rests 40 min on the dock. A pack that cuts off on the way has not reached the dock: it is carried there (charged from where it
stopped).

Printed per gauge: how often the dock was reached, the lowest true level at the dock, and the charge wasted
by docking early (the true level at the moment the robot decided to dock, above ``--dock-at``: what an ideal
gauge would have used), as a mean per docking and in total Ah over the fleet. docs/testing.md has a run.
"""
import argparse
import math
import os
import random
import sys
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), '..', 'src'))

from battery_simulator.core.battery_states import Mode, Status  # noqa: E402
from battery_simulator.core.config_files import from_mapping, preset  # noqa: E402
from battery_simulator.core.pack import make_model  # noqa: E402

PACK = 'lg_hg2_3s1p'
GAUGES = ('ideal', 'counter', 'learning')
DRIVE_TO_DOCK_S, DRIVE_TO_DOCK_A = 300.0, 2.0
REST_ON_DOCK_S = 2400.0
SEGMENT_S = 600.0
PATROL_A = (0.8, 2.2)
WAIT_A, WAIT_S, WAIT_CHANCE = 0.02, (2700.0, 5400.0), 0.08


def pack_draw(seed):
    """What one pack is, drawn from ``seed``: age, ambient, the gauge's errors."""
    draw = random.Random(seed)
    cycles = draw.uniform(0.0, 600.0)
    health = 1.0 - preset(PACK).capacity_fade_per_cycle * cycles
    return {'cycles': cycles, 'ambient_c': draw.uniform(0.0, 35.0),
            'gauge_errors': {'current_offset_a': draw.uniform(-0.02, 0.02),
                             'current_gain_error': draw.uniform(-0.01, 0.01),
                             'capacity_error': 1.0 / health - 1.0,   # it believes the new pack's capacity
                             'initial_error': draw.uniform(-3.0, 3.0)},
            'day_seed': draw.randrange(1 << 30)}


def params_for(pack, gauge):
    gauges = {'ideal': {'model': 'ideal'},
              'counter': dict(pack['gauge_errors'], model='coulomb_counter'),
              'learning': dict(pack['gauge_errors'], model='learning')}
    return from_mapping({'preset': PACK, 'initial_cycle_count': pack['cycles'], 'capacity_fade_per_cycle': 0.0,
                         'ambient_temperature_c': pack['ambient_c'], 'initial_temperature_c': pack['ambient_c'],
                         'gauge': gauges[gauge]})


class Life:
    """One pack with one gauge for a number of days, under the docking policy; the figures it saw."""

    def __init__(self, pack, gauge, dock_at, step_s):
        self.model = make_model(params_for(pack, gauge), 0.9, Mode.DISCHARGE)
        self.draw = random.Random(pack['day_seed'])
        self.dock_at, self.step_s = dock_at, step_s
        self.time_s = 0.0
        self.dockings = self.reached = 0
        self.lowest_at_dock = math.inf
        self.wasted_ah = 0.0

    def live(self, days):
        end_s = days * 86400.0
        while self.time_s < end_s:
            if self.draw.random() < WAIT_CHANCE:
                self._hold(-WAIT_A, self.draw.uniform(*WAIT_S))
            else:
                self._patrol(self.draw.uniform(*PATROL_A))
        return self

    def _reads(self):
        return self.model.gauge_reading()[0]

    def _truth(self):
        return 100.0 * self.model.state_of_charge

    def _patrol(self, current_a):
        """SEGMENT_S at ``current_a``, docking as soon as the robot reads below the policy's level."""
        left_s = SEGMENT_S
        while left_s > 0.0:
            if self._reads() < self.dock_at or self.model.status is Status.EMPTY:
                self._dock()
                return
            dt_s = min(self.step_s, left_s)
            self._step(-current_a, dt_s)
            left_s -= dt_s

    def _dock(self):
        self.dockings += 1
        decided = self._truth()
        self.wasted_ah += max(0.0, decided - self.dock_at) / 100.0 * self.model.capacity_ah
        self._hold(-DRIVE_TO_DOCK_A, DRIVE_TO_DOCK_S, stop_at_empty=True)
        if self.model.status is not Status.EMPTY:
            self.reached += 1
            self.lowest_at_dock = min(self.lowest_at_dock, self._truth())
        self.model.set_mode(Mode.CHARGE)
        while self.model.status is not Status.FULL:
            self.model.step(self.step_s)
            self.time_s += self.step_s
        self._hold(0.0, REST_ON_DOCK_S, mode=Mode.CHARGE)   # the charger holds it full: the cells rest
        self.model.set_mode(Mode.DISCHARGE)

    def _hold(self, current_a, seconds, stop_at_empty=False, mode=None):
        """``current_a`` (or the charger, ``mode`` CHARGE) for ``seconds``."""
        elapsed = 0.0
        while elapsed < seconds:
            if stop_at_empty and self.model.status is Status.EMPTY:
                break
            dt_s = min(self.step_s, seconds - elapsed)
            if mode is not None:
                self.model.set_mode(mode)
                self.model.step(dt_s)
                self.time_s += dt_s
            else:
                self._step(current_a, dt_s)
            elapsed += dt_s

    def _step(self, current_a, dt_s):
        self.model.set_mode(Mode.DISCHARGE)
        self.model.step(dt_s, current_a=current_a)
        self.time_s += dt_s


def run_study(days=20, packs=6, seed=1, dock_at=25.0, step_s=30.0):
    """{gauge: (dockings, reached, lowest true level at the dock %, wasted Ah in total, wasted % per docking)}."""
    draws = [pack_draw(seed * 1000 + index) for index in range(packs)]
    table = {}
    for gauge in GAUGES:
        lives = [Life(pack, gauge, dock_at, step_s).live(days) for pack in draws]
        dockings = sum(life.dockings for life in lives)
        capacity = sum(life.model.capacity_ah for life in lives) / len(lives)
        wasted = sum(life.wasted_ah for life in lives)
        table[gauge] = (dockings, sum(life.reached for life in lives), min(life.lowest_at_dock for life in lives),
                        wasted, 100.0 * wasted / capacity / dockings if dockings else 0.0)
    return table, draws


def main(argv=None):
    parser = argparse.ArgumentParser(prog='gauge_study.py', description=__doc__.splitlines()[0])
    parser.add_argument('--days', type=float, default=20.0, help='simulated days per pack (default 20)')
    parser.add_argument('--packs', type=int, default=6, help='packs drawn (default 6)')
    parser.add_argument('--seed', type=int, default=1, help='the draw of the packs and their days (default 1)')
    parser.add_argument('--dock-at', type=float, default=25.0, help='dock below this percentage read (default 25)')
    parser.add_argument('--step', type=float, default=30.0, help='model step, s (default 30)')
    args = parser.parse_args(argv)
    if not (args.days > 0 and args.packs >= 1 and 0 < args.dock_at < 100 and 1.0 <= args.step <= 60.0):
        parser.error('--days > 0, --packs >= 1, --dock-at in (0, 100), --step in [1, 60] s')
    started = time.monotonic()
    table, draws = run_study(args.days, args.packs, args.seed, args.dock_at, args.step)
    print('%d packs of %s (seed %d), %g days each, dock below %g %% read, %g s steps' % (
        args.packs, PACK, args.seed, args.days, args.dock_at, args.step))
    for index, pack in enumerate(draws):
        errors = pack['gauge_errors']
        print('  pack %d: %3.0f cycles, %4.1f degC, gauge offset %+.3f A, gain %+.3f, capacity belief %+.1f %%, '
              'start %+.1f points' % (index, pack['cycles'], pack['ambient_c'], errors['current_offset_a'],
                                      errors['current_gain_error'], 100.0 * errors['capacity_error'],
                                      errors['initial_error']))
    print('%-9s %9s %13s %22s %18s %20s' % ('gauge', 'dockings', 'reached dock', 'lowest true at dock %',
                                             'wasted Ah total', 'wasted % per dock'))
    for gauge in GAUGES:
        dockings, reached, lowest, wasted_ah, wasted_per_dock = table[gauge]
        print('%-9s %9d %8d (%3.0f %%) %22.1f %18.2f %20.2f' % (
            gauge, dockings, reached, 100.0 * reached / dockings if dockings else 0.0,
            lowest if math.isfinite(lowest) else math.nan, wasted_ah, wasted_per_dock))
    print('(%.0f s)' % (time.monotonic() - started))


if __name__ == '__main__':
    main()
