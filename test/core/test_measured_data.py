"""The LG HG2 preset against the measured cell tests (test/data/lg_hg2/, CC BY 4.0)."""
from dataclasses import replace
from pathlib import Path

import pytest

from battery_simulator.core.config_files import preset
from battery_simulator.core.measured_data import (charge_phase_errors, charge_runs, charge_time_error,
                                                  discharge_rmse, load_cycler_csv, measured_charge_phases,
                                                  simulate)

DATA = Path(__file__).resolve().parents[1] / 'data' / 'lg_hg2'
CELL = preset('lg_hg2_cell')
#: acceptance limits. Issue 40 refitted the charge's end (SOC 1 at the 50 mA end of charge, no step to
#: 100 %): the discharges within the RMSE before it + 1 mV (4.6 and 5.2 mV then; 4.4 and 5.5 mV now),
#: the CC and CV phases within 3 % (tools/fit_lg_hg2.py: CC -1.0 to +0.2 %, CV -1.5 to +0.9 %)
HALF_C_MV = 4.6 + 1.0
TWO_C_MV = 5.2 + 1.0
TOTAL_PERCENT = 2.5
CC_PERCENT = 3.0
CV_PERCENT = 3.0


def measured_discharge_rmse(name, excluded_end_soc):
    samples = load_cycler_csv(DATA / name)
    error, compared = discharge_rmse(CELL, samples, excluded_end_soc)
    assert compared > 0.9 * len(samples) * (1 - excluded_end_soc) - 2
    return error


def test_half_c_discharge_voltage_rmse_within_its_limit():
    error = measured_discharge_rmse('549_Dis_0p5C.csv', 0.0)
    assert error <= HALF_C_MV / 1000, 'RMSE %.1f mV' % (1000 * error)


def test_two_c_discharge_voltage_rmse_within_its_limit():
    error = measured_discharge_rmse('549_Dis_2C.csv', 0.03)
    assert error <= TWO_C_MV / 1000, 'RMSE %.1f mV' % (1000 * error)


def test_two_c_discharge_warms_the_cell_like_the_measurement():
    samples = load_cycler_csv(DATA / '549_Dis_2C.csv')
    params = replace(CELL, ambient_temperature_c=samples[0].temperature_c)
    _, _, temperatures = simulate(params, samples, state_of_charge=1.0)
    measured_rise = samples[-1].temperature_c - samples[0].temperature_c
    simulated_rise = temperatures[-1] - samples[0].temperature_c
    assert simulated_rise == pytest.approx(measured_rise, abs=1.0)


@pytest.mark.parametrize('index', range(4))
def test_cc_cv_charge_reaches_termination_within_its_limit_of_the_measured_time(index):
    runs = charge_runs(load_cycler_csv(DATA / '549_Charge.csv'))
    assert len(runs) == 4
    rest, run = runs[index]
    assert run[0].current_a == pytest.approx(3.0, abs=0.01), 'a 3 A CC-CV charge'
    params = replace(CELL, charge_current_a=3.0, termination_current_a=run[-1].current_a)
    error = charge_time_error(params, rest, run)
    assert abs(error) <= TOTAL_PERCENT / 100, 'simulated time to full off by %+.1f %%' % (100 * error)


@pytest.mark.parametrize('index', range(4))
def test_cc_and_cv_phases_each_within_their_limit_of_the_measured_durations(index):
    rest, run = charge_runs(load_cycler_csv(DATA / '549_Charge.csv'))[index]
    cc_error, cv_error = charge_phase_errors(CELL, rest, run)
    assert abs(cc_error) <= CC_PERCENT / 100, 'CC phase off by %+.1f %%' % (100 * cc_error)
    assert abs(cv_error) <= CV_PERCENT / 100, 'CV phase off by %+.1f %%' % (100 * cv_error)


def test_the_measured_cc_phase_ends_where_the_voltage_reaches_the_cv_level():
    rest, run = charge_runs(load_cycler_csv(DATA / '549_Charge.csv'))[0]
    cc_s, cv_s = measured_charge_phases(rest, run)
    # the last 3 A row is 2640 s in at 4.1927 V, rising 20.4 mV a minute; the next is CV
    assert cc_s == pytest.approx(2640.0 + 60.0 * (4.19995 - 4.19271) / (4.19271 - 4.17231), abs=0.5)
    assert cc_s + cv_s == pytest.approx(run[-1].time_s - rest.time_s)


def test_loader_names_the_line_of_a_bad_row(tmp_path):
    lines = (DATA / '549_Dis_2C.csv').read_text(encoding='latin-1').splitlines()
    lines[32] = lines[32].replace('DCH,', 'DCH,x', 1)  # corrupt the Prog Time
    path = tmp_path / 'bad.csv'
    path.write_text('\n'.join(lines), encoding='latin-1')
    with pytest.raises(ValueError, match='line 33'):
        load_cycler_csv(path)
