#!/usr/bin/python3
"""Fit the LG HG2 cell preset to the measured tests in test/data/lg_hg2/.

    tools/fit_lg_hg2.py            # print the fitted preset and its errors
    tools/fit_lg_hg2.py --write    # also write config/presets/lg_hg2_cell.yaml
    tools/fit_lg_hg2.py --plot docs/model_vs_hg2.png   # the shipped preset against the measurements, no fit

1. OCV(SOC) from the C/20 discharge, its small IR drop added back, averaged
   with the C/20 charge (IR drop taken off) to split the hysteresis.
2. R0, R1 and tau1 by grid search minimising the voltage RMSE of the 0.5C and
   2C discharges (the 2C one without its last 3 % SOC, as in the tests).
3. The lumped thermal mass and its transfer to ambient from the 2C warming.
"""
import argparse
import itertools
import sys
from dataclasses import replace
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / 'src'))

from battery_simulator.core.measured_data import (charge_runs, charge_time_error,  # noqa: E402
                                             discharge_rmse, load_cycler_csv, rmse, simulate)
from battery_simulator.core.parameters import BatteryParameters, preset  # noqa: E402

DATA = ROOT / 'test' / 'data' / 'lg_hg2'
SOC_GRID = (0.0, 0.005, 0.01, 0.02, 0.03, 0.04, 0.05, 0.06, 0.08, 0.1, 0.125, 0.15, 0.2,
            0.25, 0.3, 0.35, 0.4, 0.45, 0.5, 0.55, 0.6, 0.65, 0.7, 0.75, 0.8, 0.85, 0.9,
            0.925, 0.95, 0.975, 0.99, 1.0)
CHARGE_VOLTAGE_V = 4.2
CUTOFF_VOLTAGE_V = 2.8
C20_RESISTANCE_OHM = 0.05  # DC resistance at C/20 (R0 + R1 + diffusion), for the IR correction
EXCLUDED_END_SOC = 0.03
RMSE_LIMIT_05C_V = 0.025    # acceptance limits, as in test/unit/test_validation.py
RMSE_LIMIT_2C_V = 0.035
CHARGE_TIME_LIMIT = 0.05
TERMINATION_CURRENT_A = 0.05  # the cycler's CV end
UP_WEIGHT = 0.0


def _interpolate(points, x):
    """Linear interpolation in sorted (x, y) points, clamped at the ends."""
    xs = [p[0] for p in points]
    if x <= xs[0]:
        return points[0][1]
    if x >= xs[-1]:
        return points[-1][1]
    k = max(i for i, v in enumerate(xs) if v <= x)
    (x0, y0), (x1, y1) = points[k], points[k + 1]
    return y0 + (y1 - y0) * (x - x0) / (x1 - x0)


def ocv_table():
    """SOC grid and OCV per cell from the C/20 discharge and charge."""
    samples = load_cycler_csv(DATA / '549_C20DisCh.csv')
    discharge = [s for s in samples if s.status == 'DCH']
    charge = [s for s in samples if s.status == 'CHA']
    discharged_ah = -discharge[-1].capacity_ah
    charge_end_ah = charge[-1].capacity_ah
    down = sorted((1.0 + s.capacity_ah / discharged_ah, s.voltage_v - s.current_a * C20_RESISTANCE_OHM)
                  for s in discharge)
    # The charge is aligned at its full end: the cell holds discharged_ah.
    up = sorted((1.0 - (charge_end_ah - s.capacity_ah) / discharged_ah,
                 s.voltage_v - s.current_a * C20_RESISTANCE_OHM)
                for s in charge if s.current_a > 0.14)  # CC part only
    volts = []
    for soc in SOC_GRID:
        v = (1 - UP_WEIGHT) * _interpolate(down, soc) + UP_WEIGHT * _interpolate(up, soc)
        volts.append(round(max(v, volts[-1] + 0.001) if volts else v, 4))
    volts[0] = min(volts[0], CUTOFF_VOLTAGE_V)
    volts[-1] = max(volts[-1], CHARGE_VOLTAGE_V)
    return list(SOC_GRID), volts, discharged_ah


def discharge_errors(params):
    """Voltage RMSE (V) over the 0.5C discharge and the 2C discharge (to 97 % DoD)."""
    return [discharge_rmse(params, load_cycler_csv(DATA / name), exclude)[0]
            for name, exclude in (('549_Dis_0p5C.csv', 0.0), ('549_Dis_2C.csv', EXCLUDED_END_SOC))]


def charge_time_errors(params):
    """Relative error of the simulated time to full for each measured 3 A CC-CV charge."""
    return [charge_time_error(params, rest, run)
            for rest, run in charge_runs(load_cycler_csv(DATA / '549_Charge.csv'))]


def score(params):
    """The worst figure relative to its acceptance limit (below 1 passes all)."""
    rmse_05c, rmse_2c = discharge_errors(params)
    charge = max(abs(e) for e in charge_time_errors(params))
    return max(rmse_05c / RMSE_LIMIT_05C_V, rmse_2c / RMSE_LIMIT_2C_V, charge / CHARGE_TIME_LIMIT)


def fit_resistances(params):
    candidates = (replace(params, r0_ohm=r0, r1_ohm=r1, tau1_s=tau) for r0, r1, tau in itertools.product(
        (0.018, 0.02, 0.022, 0.024, 0.026, 0.028), (0.03, 0.035, 0.04, 0.045, 0.05),
        (800.0, 1200.0, 1600.0, 2000.0, 2500.0, 3000.0)))
    return min(candidates, key=score)


def fit_thermal(params):
    samples = load_cycler_csv(DATA / '549_Dis_2C.csv')
    ambient = samples[0].temperature_c
    best = None
    for capacity, transfer in itertools.product((45.0, 60.0, 80.0, 100.0, 130.0, 160.0, 200.0, 250.0, 300.0),
                                                (0.05, 0.1, 0.15, 0.2, 0.3, 0.4, 0.6, 0.8, 1.0)):
        candidate = replace(params, cell_heat_capacity_j_per_k=capacity,
                            cell_heat_transfer_w_per_k=transfer, ambient_temperature_c=ambient)
        _, _, temperatures = simulate(candidate, samples, 1.0)
        score = rmse(temperatures, [s.temperature_c for s in samples])
        if best is None or score < best[0]:
            best = (score, capacity, transfer)
    return replace(params, cell_heat_capacity_j_per_k=best[1], cell_heat_transfer_w_per_k=best[2]), best[0]


def plot_against_measurements(params, output):
    """Terminal voltage and temperature, model against measurement, for the C/20, 0.5C and 2C discharges."""
    import matplotlib
    matplotlib.use('Agg')
    from matplotlib import pyplot

    figure, (volts_axis, heat_axis) = pyplot.subplots(1, 2, figsize=(12, 4.8), gridspec_kw={'width_ratios': [2, 1]})
    c20 = load_cycler_csv(DATA / '549_C20DisCh.csv', status='DCH')
    volts_axis.plot([c20[0].capacity_ah - s.capacity_ah for s in c20], [s.voltage_v for s in c20], '.',
                    color='tab:green', markersize=1.5, label='C/20 (0.15 A) measured')
    volts_axis.plot([(1.0 - soc) * params.cell_capacity_ah for soc in params.ocv_soc], params.ocv_voltage_v, '-',
                    color='tab:green', linewidth=1.0, label='model OCV table (fitted to C/20)')
    for name, label, colour in (('549_Dis_0p5C.csv', '0.5C (1.5 A)', 'tab:blue'),
                                ('549_Dis_2C.csv', '2C (6 A)', 'tab:red')):
        samples = load_cycler_csv(DATA / name)
        test = replace(params, ambient_temperature_c=samples[0].temperature_c)
        _, voltages, temperatures = simulate(test, samples, state_of_charge=1.0)
        delivered = [samples[0].capacity_ah - s.capacity_ah for s in samples]
        error_mv = 1000.0 * rmse(voltages, [s.voltage_v for s in samples])
        volts_axis.plot(delivered, [s.voltage_v for s in samples], '.', color=colour, markersize=2.5,
                        label='%s measured' % label)
        volts_axis.plot(delivered, voltages, '-', color=colour, linewidth=1.2,
                        label='%s model (RMSE %.0f mV)' % (label, error_mv))
        if name == '549_Dis_2C.csv':
            minutes = [s.time_s / 60.0 for s in samples]
            heat_axis.plot(minutes, [s.temperature_c for s in samples], '.', color=colour, markersize=3,
                           label='measured')
            heat_axis.plot(minutes, temperatures, '-', color=colour, label='model')
    volts_axis.set_xlabel('charge delivered (Ah)')
    volts_axis.set_ylabel('terminal voltage (V)')
    volts_axis.set_title('LG HG2 cell: model (preset lg_hg2_cell) against measured discharges', fontsize=10)
    volts_axis.legend(fontsize=7, loc='lower left')
    volts_axis.grid(alpha=0.3)
    heat_axis.set_xlabel('time (min)')
    heat_axis.set_ylabel('cell temperature (°C)')
    heat_axis.set_title('2C discharge: warming', fontsize=10)
    heat_axis.legend(fontsize=8)
    heat_axis.grid(alpha=0.3)
    figure.text(0.01, 0.01, 'Data: Kollmeyer, Vidal, Naguib, Skells (2020), LG 18650HG2 Li-ion Battery Data, '
                'Mendeley Data V3, doi:10.17632/cp3473x7xv.3, CC BY 4.0', fontsize=7, color='dimgrey')
    figure.tight_layout(rect=(0, 0.03, 1, 1))
    figure.savefig(output, dpi=110)
    pyplot.close(figure)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--write', action='store_true', help='write config/presets/lg_hg2_cell.yaml')
    parser.add_argument('--plot', metavar='PNG', help='plot the shipped preset against the measured '
                        'discharges into PNG and exit')
    args = parser.parse_args()
    if args.plot:
        plot_against_measurements(preset('lg_hg2_cell'), args.plot)
        print('wrote %s' % args.plot)
        return
    soc, volts, capacity = ocv_table()
    params = BatteryParameters(name='lg_hg2_cell', cell_capacity_ah=round(capacity, 3),
                               ocv_soc=tuple(soc), ocv_voltage_v=tuple(volts),
                               cell_charge_voltage_v=CHARGE_VOLTAGE_V,
                               cell_cutoff_voltage_v=CUTOFF_VOLTAGE_V,
                               charge_current_a=3.0, termination_current_a=TERMINATION_CURRENT_A,
                               load_current_a=1.5)
    # Resistance and warming depend on each other (Arrhenius): alternate.
    params, thermal_rmse = fit_thermal(replace(params, r0_ohm=0.03, r1_ohm=0.02, tau1_s=60.0))
    for _ in range(2):
        params = fit_resistances(params)
        params, thermal_rmse = fit_thermal(params)
    print('r0_ohm %.4f  r1_ohm %.4f  tau1_s %.0f' % (params.r0_ohm, params.r1_ohm, params.tau1_s))
    print('voltage RMSE 0.5C %.1f mV, 2C %.1f mV' % tuple(1000 * e for e in discharge_errors(params)))
    print('time to full, relative error: %s' % ' '.join('%+.3f' % e for e in charge_time_errors(params)))
    print('thermal C %.0f J/K, G %.2f W/K, RMSE %.2f K' % (
        params.cell_heat_capacity_j_per_k, params.cell_heat_transfer_w_per_k, thermal_rmse))
    text = preset_yaml(params)
    if args.write:
        PRESET.write_text(text, encoding='utf-8')
        print('wrote %s' % PRESET)
    else:
        print(text)


def preset_yaml(params):
    return PRESET_TEMPLATE % dict(
        capacity=params.cell_capacity_ah, soc=list(params.ocv_soc), volts=list(params.ocv_voltage_v),
        r0=params.r0_ohm, r1=params.r1_ohm, tau=params.tau1_s,
        heat_capacity=params.cell_heat_capacity_j_per_k, transfer=params.cell_heat_transfer_w_per_k)


PRESET = ROOT / 'config' / 'presets' / 'lg_hg2_cell.yaml'
PRESET_TEMPLATE = '''\
# One LG 18650HG2 Li-ion cell (1S1P, 3.0 Ah nominal, 4.2 V max), as measured.
# Written by tools/fit_lg_hg2.py from the cell tests in test/data/lg_hg2/:
# Kollmeyer, P.; Vidal, C.; Naguib, M.; Skells, M. (2020), "LG 18650HG2 Li-ion
# Battery Data and Example Deep Neural Network xEV SOC Estimator Script",
# Mendeley Data, V3, doi:10.17632/cp3473x7xv.3, CC BY 4.0.
# Capacity: the C/20 discharge from full to 2.8 V. OCV: that discharge with its
# IR drop added back. R0/R1/tau1: fitted to the 0.5C and 2C discharges and the
# 3 A CC-CV charges. Thermal: fitted to the 2C warming (cell in the test rig).
name: lg_hg2_cell
source: LG HG2 cell tests, Kollmeyer et al. 2020, doi:10.17632/cp3473x7xv.3 (CC BY 4.0)
cells_series: 1
cells_parallel: 1
cell_capacity_ah: %(capacity).3f
ocv_soc: %(soc)s
ocv_voltage_v: %(volts)s
r0_ohm: %(r0).4f
r1_ohm: %(r1).4f
tau1_s: %(tau).0f
coulombic_efficiency: 0.999
cell_charge_voltage_v: 4.2
cell_cutoff_voltage_v: 2.8
charge_current_a: 1.5           # 0.5C (the datasheet's standard charge)
termination_current_a: null     # C/20
load_current_a: 1.5             # 0.5C
cell_heat_capacity_j_per_k: %(heat_capacity).0f
cell_heat_transfer_w_per_k: %(transfer).2f
# Limits from the LG HG2 datasheet (LG Chem, INR18650HG2, 2014): 20 A maximum
# continuous discharge, 4 A maximum charge, discharge temperature up to 75 degC.
cell_max_discharge_current_a: 20.0
cell_max_charge_current_a: 4.0
protection_temperature_c: 75.0
serial_number: LG-HG2-549
'''


if __name__ == '__main__':
    main()
