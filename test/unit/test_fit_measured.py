"""battery_fit on measured logs (issue 39): small measured logs in test/data/measured/ (README.md there gives
their sources and citations), each fitted on its first 60 % and scored on the rest through battery_replay's
function, in mV per true series cell. Plus the units, the idle term and a user's files."""
import gzip
import os
import shutil
import subprocess
import sys

import numpy as np
import pytest

import fit_logs
from battery_simulator.cli import fit as fit_cli
from battery_simulator.core.fit.circuit import counted_charge_ah

DATA = os.path.join(os.path.dirname(os.path.abspath(__file__)), '..', 'data', 'measured')
I3 = os.path.join(DATA, 'bmw_i3_TripA01.csv.gz')
A123 = os.path.join(DATA, 'calce_a123_dst_20C.csv.gz')


def _columns(path):
    with gzip.open(path, 'rt') as stream:
        return np.genfromtxt(stream, delimiter=',', names=True)


def test_bmw_i3_drive_96_cells_bms_capacity_and_temperature(tmp_path):
    data = _columns(I3)
    charge = np.concatenate([[0.0], np.cumsum(data['current'][:-1] * np.diff(data['time']))]) / 3600.0
    bms_capacity = np.polyfit(charge, data['percentage'], 1)[0] ** -1   # the BMS's coulomb count, whole drive
    figures = fit_logs.fit_and_score(I3, str(tmp_path), cells=96)
    assert figures['cells_series'] == 96, figures['report']
    assert figures['capacity_ah'] == pytest.approx(bms_capacity, rel=0.05), 'capacity %.1f Ah, BMS %.1f Ah' % (
        figures['capacity_ah'], bms_capacity)
    assert figures['temperature_k'] <= 5.0, 'the model\'s temperature %.1f K from the logged' % figures['temperature_k']
    assert figures['held_mv'] <= 15.0, 'held out %.1f mV per cell (at most 15)' % figures['held_mv']


def test_a123_lfp_cell_detected_with_its_capacity(tmp_path):
    data = _columns(A123)
    charge = np.concatenate([[0.0], np.cumsum(data['current'][:-1] * np.diff(data['time']))]) / 3600.0
    full = int(np.argmax(charge))
    measured_capacity = charge[full] - charge[-1]   # from the CC-CV charge's end to 2.0 V
    figures = fit_logs.fit_and_score(A123, str(tmp_path), cells=1)
    assert 'chemistry                      lfp' in figures['report'], figures['report']
    assert 'preset: a123_lfp_cell' in open(figures['config']).read()
    assert figures['cells_series'] == 1
    assert figures['capacity_ah'] == pytest.approx(measured_capacity, rel=0.05), 'capacity %.3f Ah, measured %.3f Ah' % (
        figures['capacity_ah'], measured_capacity)
    assert figures['held_mv'] <= LFP_HELD_MV, 'held out %.1f mV per cell' % figures['held_mv']


#: the DST's last 40 % (down to 2.0 V) replayed with the logged current (see docs/fit.md for why not lower)
LFP_HELD_MV = 70.0
