"""tools/gauge_study.py (issue 43 item 5): the docking study runs, and its figures mean what they say (an ideal
gauge docks at the policy's level: it wastes nothing and reaches the dock 25 % less the drive there)."""
import importlib.util
from pathlib import Path

import pytest

TOOL = Path(__file__).resolve().parents[2] / 'tools' / 'gauge_study.py'


@pytest.fixture(scope='module')
def study():
    spec = importlib.util.spec_from_file_location('gauge_study', TOOL)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_one_day_of_one_pack_with_each_gauge(study):
    table, draws = study.run_study(days=1, packs=1, seed=1)
    assert set(table) == {'ideal', 'counter', 'learning'} and len(draws) == 1
    dockings, reached, lowest, wasted_ah, wasted_per_dock = table['ideal']
    assert dockings >= 3 and reached == dockings
    drive_points = 100.0 * study.DRIVE_TO_DOCK_A * study.DRIVE_TO_DOCK_S / 3600.0 / 2.781
    assert 25.0 - drive_points - 3.0 <= lowest <= 25.0 - drive_points + 1.0, lowest
    assert wasted_ah == 0.0 and wasted_per_dock == 0.0
    for gauge in ('counter', 'learning'):
        assert table[gauge][0] >= 3 and 0 <= table[gauge][1] <= table[gauge][0]


def test_the_same_seed_draws_the_same_packs(study):
    assert study.pack_draw(7) == study.pack_draw(7) != study.pack_draw(8)
