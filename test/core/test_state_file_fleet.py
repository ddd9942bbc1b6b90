"""A fleet's saved states are written often enough that a resume after SIGKILL is within 1 % (issue 33, low):
at x300 an update of a ROS 2 fleet (1 Hz) is 300 s of battery, 4.5 points of a 3 Ah pack at 1.5 A."""
import json
import random

import pytest

from battery_simulator.core.state_file import SAVE_EARLY, FleetStateFile, fleet_save_period_s

LOAD_A, CAPACITY_AH = 1.5, 3.0


@pytest.mark.parametrize('time_scale, points', [(1.0, 0.34), (22.0, 0.34), (60.0, 0.34), (300.0, 0.34),
                                                 (1000.0, 0.7)])
def test_the_battery_time_between_two_writes_is_within_1_percent(time_scale, points):
    period_s = fleet_save_period_s(time_scale)
    assert 0.05 <= period_s <= 0.5
    lost_points = 100.0 * LOAD_A * period_s * time_scale / 3600.0 / CAPACITY_AH
    assert lost_points <= points, 'x%g: a write every %.3f s loses up to %.2f points' % (
        time_scale, period_s, lost_points)


def test_a_fleet_state_file_is_written_at_its_period(tmp_path):
    now = [100.0]
    path = tmp_path / 'fleet.json'
    store = FleetStateFile(str(path), clock=lambda: now[0], period_s=fleet_save_period_s(300.0))
    robot = store.robot('robot0')
    written = []
    for step in range(30):   # 1.5 s of wall time at 20 Hz
        now[0] += 0.05
        robot.maybe_save({'state_of_charge': 0.9 - 0.001 * step})
        store.write_if_due()
        written.append(json.loads(path.read_text())['robots']['robot0']['state_of_charge'])
    behind = [0.9 - 0.001 * step - level for step, level in enumerate(written)]
    assert max(abs(b) for b in behind) <= 0.0011, 'at most one 0.05 s step behind: %s' % behind


@pytest.mark.parametrize('time_scale', [22.0, 300.0])
def test_a_fleet_state_file_keeps_its_cadence_with_a_timer_at_the_period(tmp_path, time_scale):
    """ROS 2's fleet host calls write_if_due from a timer at the period and after each update (1 Hz); a timer
    a hair early (its jitter) skipped every other write: every 1.0 s at x22 where the contract says 0.5 s,
    0.12-0.32 s at x300 for 0.067 s (issue 40 item 10). The gap between writes stays within the period and
    its jitter, after the first write (which an update may make between two ticks of the timer: the gap after
    it is up to two periods, once)."""
    period_s = fleet_save_period_s(time_scale)
    now = [0.0]
    store = FleetStateFile(str(tmp_path / 'fleet.json'), clock=lambda: now[0], period_s=period_s)
    robot = store.robot('robot0')
    jitter = random.Random(40)
    calls = sorted([k * period_s + jitter.uniform(-0.002, 0.002) for k in range(1, int(10.0 / period_s))] +
                   [0.3 + k * 1.0 for k in range(10)])   # the timer, and the updates at 1 Hz
    writes = []
    for at in calls:
        now[0] = at
        robot.maybe_save({'state_of_charge': 0.5})
        if store.write_if_due():
            writes.append(at)
    gaps = [b - a for a, b in zip(writes[1:], writes[2:])]   # after the first write (the startup)
    assert max(gaps) <= (1.0 + SAVE_EARLY) * period_s + 0.005, 'x%g: writes %.3f s apart at most, period %.3f s' % (
        time_scale, max(gaps), period_s)
    assert sum(gaps) / len(gaps) <= 1.02 * period_s, 'x%g: writes %.3f s apart on average, period %.3f s' % (
        time_scale, sum(gaps) / len(gaps), period_s)
