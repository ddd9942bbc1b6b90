"""core/time_base.py under sim time: two /clock publishers interleaving their readings (issue 33 item 14)
count no faster than one clock, while one honest clock (fast, stalling, reset) counts as it always did."""
import random

import pytest

from battery_simulator.core.battery import Battery
from battery_simulator.core.config_files import preset
from battery_simulator.core.time_base import TimeBase


def sim_base():
    return TimeBase(1.0, zero_is_unset=True, max_jump_s=3600.0, hold_jumps=True)


def two_clocks(offset_s, step_s, readings, pick):
    """Readings of two clocks ``offset_s`` apart, both ``step_s`` per update; ``pick(i)``: True for the
    second clock's reading at update i. The first clock runs alone for the first 5 updates (one held
    for a while, as a simulator paused at start), the second one starts after them."""
    return [1000.0] * 3 + [1000.0 + i * step_s + (offset_s if i > 5 and pick(i) else 0.0) for i in range(readings)]


@pytest.mark.parametrize('offset_s', [600.0, -600.0, 3000.0, 40.0])
@pytest.mark.parametrize('seed', range(8))
def test_two_interleaving_clocks_count_no_faster_than_one(offset_s, seed):
    step_s = 6.0                              # sim_clock at speed 60, 10 Hz updates
    chooser = random.Random(seed)
    readings = two_clocks(offset_s, step_s, 1000, lambda i: chooser.random() < 0.5)
    base = sim_base()
    counted = sum(base.elapsed(now) for now in readings)
    one_clock_s = 999 * step_s
    assert counted <= one_clock_s + step_s, \
        'two clocks %g s apart counted %.0f s where one clock ran %.0f s' % (offset_s, counted, one_clock_s)
    assert base.jumps_back > 0, 'the switches back are reported (the warning naming the publishers)'


@pytest.mark.parametrize('run, owed_s', [(1, 0.0), (2, 0.0), (5, 0.0), (10, 0.0), (150, 600.0)])
def test_two_clocks_taking_turns_in_runs_count_no_faster_than_one(run, owed_s):
    """Runs of 150 readings of the second clock (900 s, longer than the 600 s between the clocks) confirm
    its jump as one clock's: the jump is owed as soon as a reading lands on the first clock's line again,
    and repaid; at most one jump is outstanding at any time."""
    base = sim_base()
    readings = two_clocks(600.0, 6.0, 600, lambda i: (i // run) % 2 == 1)
    counted = sum(base.elapsed(now) for now in readings)
    assert counted <= 599 * 6.0 + 6.0 + owed_s, 'runs of %d: counted %.1f s of %.0f s' % (run, counted, 599 * 6.0)


def test_a_fast_clock_and_its_stall_count_all_their_time():
    """sim_clock at speed 1000, 10 Hz updates: 100 s per update, 1000 s across a 1 s stall of the process;
    the stall counts in full once the readings after it have gone on for as long (10 updates)."""
    base = sim_base()
    readings = [1000.0 + 100.0 * i for i in range(10)] + [2900.0 + 100.0 * i for i in range(20)]
    counted = [base.elapsed(now) for now in readings]
    assert sum(counted) == pytest.approx(readings[-1] - readings[0])
    stall = readings.index(2900.0)
    assert counted[stall:stall + 10] == [0.0] * 10, 'held'
    assert counted[stall + 10] == pytest.approx(2000.0), 'then counted in full'
    assert counted[stall + 11] == pytest.approx(100.0)


def test_a_reset_and_a_clock_that_catches_up_with_an_old_line():
    base = sim_base()
    counted = sum(base.elapsed(now) for now in [5000.0, 5010.0, 5020.0])        # 20 s
    counted += sum(base.elapsed(now) for now in [100.0 + 10.0 * i for i in range(600)])   # a reset: 5990 s
    assert counted == pytest.approx(20.0 + 5990.0), 'the clock passing the old line counts on'


def test_a_battery_under_two_clocks_drains_no_faster_than_under_one():
    def drained(readings):
        clock = [readings[0]]
        battery = Battery(preset('lg_hg2_3s1p'), 80.0, clock=lambda: clock[0], sim_time=True, max_time_jump=3600.0)
        start = battery.update().snapshot.percentage
        for now in readings[1:]:
            clock[0] = now
            end = battery.update().snapshot.percentage
        return start - end
    chooser = random.Random(3)
    one = drained(two_clocks(600.0, 0.1, 50, lambda i: False))
    two = drained(two_clocks(600.0, 0.1, 50, lambda i: chooser.random() < 0.5))
    assert 0.0 <= two <= one * 1.05 + 1e-9, 'two clocks drained %.3f points, one %.3f' % (two, one)


@pytest.mark.parametrize('seed', range(5))
def test_an_honest_clock_with_jittery_updates_counts_all_its_time(seed):
    """A 5 Hz update timer on a 20x sim clock: steps of 0.2 s to 1.2 s of ROS time, now and then a lag
    of 3 s; nothing is lost or counted twice (a held step counts once the clock carries on)."""
    chooser = random.Random(seed)
    readings, now = [], 1.7e9
    for i in range(500):
        now += 3.0 if chooser.random() < 0.02 else chooser.uniform(0.2, 1.2)
        readings.append(now)
    readings += [now + 0.5 * i for i in range(1, 20)]
    base = sim_base()
    counted = sum(base.elapsed(now) for now in readings)
    assert counted == pytest.approx(readings[-1] - readings[0], abs=1e-3), 'seed %d: %.3f s of %.3f s' % (
        seed, counted, readings[-1] - readings[0])


# -- two clocks whatever the delivery delays (issue 40 item 15) -------------------------------------

def delivered_readings(seed, offset_s, delay, stall_max_s, update_hz, speed=20.0, seconds=11.0, tick_s=0.005):
    """What a battery reads under two /clock publishers ``offset_s`` apart (each ticking every ``tick_s`` of
    wall time at ``speed``, in a random order each tick), on a loaded machine, deterministically (``seed``):

      - delay 'stall': the subscriber's executor stalls up to ``stall_max_s``, then takes each publisher's
        queue (keep last 10) in turn, one publisher's messages after the other's;
      - delay 'lag': the second publisher's messages arrive up to ``stall_max_s`` late (in order).

    The battery reads the newest delivered value at ``update_hz`` (with jitter, and now and then late).
    Returns (readings, one clock's seconds over the same wall time)."""
    rng = random.Random(seed)
    sent = []
    for k in range(int(seconds / tick_s)):
        for clock in ((0, 1) if rng.random() < 0.5 else (1, 0)):
            sent.append((k * tick_s, 1.7e9 + speed * k * tick_s + offset_s * clock, clock))
    delivered = []   # (wall time, value) in delivery order
    if delay == 'stall':
        queues, index, now = ([], []), 0, 0.0
        while now < seconds:
            now += rng.uniform(0.0, stall_max_s)
            while index < len(sent) and sent[index][0] <= now:
                queues[sent[index][2]].append(sent[index][1])
                index += 1
            for clock in ((0, 1) if rng.random() < 0.5 else (1, 0)):
                delivered += [(now, value) for value in queues[clock][-10:]]
                queues[clock].clear()
    else:
        latest = [0.0, 0.0]
        for at, value, clock in sent:
            latest[clock] = max(latest[clock], at + rng.uniform(0.0, stall_max_s if clock else 0.01))
            delivered.append((latest[clock], value))
        delivered.sort(key=lambda pair: pair[0])
    readings, index, clock_value, now, first = [], 0, 0.0, 0.0, None
    while now < seconds:
        now += rng.uniform(0.5, 1.5) / update_hz + (rng.uniform(0.0, stall_max_s) if rng.random() < 0.2 else 0.0)
        while index < len(delivered) and delivered[index][0] <= now:
            clock_value = delivered[index][1]
            index += 1
        if clock_value:
            first = now if first is None else first
            readings.append(clock_value)
    return readings, speed * (now - first)


@pytest.mark.parametrize('offset_s', [600.0, -600.0, 3000.0])
@pytest.mark.parametrize('delay', ['stall', 'lag'])
@pytest.mark.parametrize('stall_max_s', [0.3, 1.0])
@pytest.mark.parametrize('update_hz', [2.0, 10.0])
def test_two_clocks_count_no_faster_than_one_whatever_the_delivery_delays(offset_s, delay, stall_max_s, update_hz):
    """Two clocks 600 s apart at 20x (test_hardening's), their messages delivered late and in bursts as on a
    loaded machine: the time counted stays within one clock's (before: 9.98 points where one clock drained
    3.28 on a loaded machine; here up to 3.3 times one clock's time, the second clock's first reading counted
    as a step of a line the loaded battery had read once or twice)."""
    for seed in range(4):
        readings, one_clock_s = delivered_readings(seed, offset_s, delay, stall_max_s, update_hz)
        base = sim_base()
        counted = sum(base.elapsed(now) for now in readings)
        assert counted <= 1.05 * one_clock_s + 20.0 * stall_max_s, \
            'seed %d: two clocks %g s apart counted %.0f s where one clock ran %.0f s' % (
                seed, offset_s, counted, one_clock_s)
