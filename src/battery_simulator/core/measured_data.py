"""Measured cell tests (cycler CSV exports) and the model run against them (no rospy).

Used to fit the LG HG2 preset (tools/fit_lg_hg2.py) and to validate the model
(test/unit/test_validation.py). The format is the one in test/data/lg_hg2/.
"""
import csv
import math
from collections import namedtuple
from dataclasses import replace

from battery_simulator.core.battery_model import BatteryModel, Mode, OcvCurve, Status

#: One logged sample: time since the start of the file's first step (s), step number,
#: status (DCH, CHA, PAU), voltage (V), current (A, negative discharging),
#: temperature (degC), capacity counter (Ah).
Sample = namedtuple('Sample', 'time_s step status voltage_v current_a temperature_c capacity_ah')


def _seconds(text):
    hours, minutes, seconds = text.split(':')
    return int(hours) * 3600 + int(minutes) * 60 + float(seconds)


def load_cycler_csv(path, status=None):
    """The samples of a cycler export, optionally only those with ``status``.

    Raises ValueError naming the file and line of a malformed row.
    """
    samples = []
    start = None
    with open(path, encoding='latin-1', newline='') as stream:
        rows = csv.reader(stream)
        for line, row in enumerate(rows, start=1):
            if len(row) < 13 or row[2] not in ('DCH', 'CHA', 'PAU'):
                continue  # header, units or the end marker
            try:
                time_s = _seconds(row[3])
                step_time_s = _seconds(row[4])
                sample = Sample(time_s, int(row[1]), row[2], float(row[8]), float(row[9]),
                                float(row[10]), float(row[11]))
            except ValueError as error:
                raise ValueError('%s line %d: %s' % (path, line, error)) from None
            if samples and time_s <= samples[-1].time_s + 0.01:
                continue  # the cycler repeats a step's last row
            start = time_s - step_time_s if start is None else start
            samples.append(sample._replace(time_s=time_s - start))
    if status is not None:
        samples = [s for s in samples if s.status == status]
    return samples


def simulate(params, samples, state_of_charge, mode=None, max_step_s=10.0):
    """Run the model through the measured current of ``samples``.

    The run starts at time 0 (the start of the first step). Each sample's
    current is held from the previous sample's time to its own (the cycler
    logs the current of the interval that ends there). With
    ``mode`` the model's own mode drives the current instead (e.g. its CC-CV
    charger). Returns the model and the simulated pack voltage (V) and
    temperature (degC) at each sample.
    """
    model = BatteryModel(params, state_of_charge=state_of_charge, mode=mode or Mode.IDLE)
    voltages, temperatures = [], []
    previous_s = 0.0
    for sample in samples:
        remaining, previous_s = sample.time_s - previous_s, sample.time_s
        steps = max(1, int(math.ceil(remaining / max_step_s)))
        for _ in range(steps):
            if mode is None:
                model.step(remaining / steps, current_a=sample.current_a)
            else:
                model.step(remaining / steps)
        voltages.append(model.voltage_v)
        temperatures.append(model.temperature_c)
    return model, voltages, temperatures


def rmse(simulated, measured):
    """Root-mean-square difference of two equal-length sequences."""
    return math.sqrt(sum((a - b) ** 2 for a, b in zip(simulated, measured)) / len(measured))


def charge_runs(samples):
    """Each charge of a cycler export: (the rest sample before it, its CHA samples)."""
    runs, rest, current_run = [], None, None
    for sample in samples:
        if sample.status != 'CHA':
            rest, current_run = sample, None
        elif current_run is None:
            current_run = [sample]
            runs.append((rest, current_run))
        else:
            current_run.append(sample)
    return [(rest, run) for rest, run in runs if rest is not None]


def time_to_full(model, max_step_s=10.0, limit_s=86400.0):
    """Seconds of the model's own CC-CV charge until it reports FULL (None if never)."""
    elapsed = 0.0
    model.set_mode(Mode.CHARGE)
    while model.status is not Status.FULL:
        if elapsed >= limit_s:
            return None
        model.step(max_step_s)
        elapsed += max_step_s
    return elapsed


def run_soc(samples):
    """SOC along a measured discharge, relative to the charge that run delivered."""
    start_ah = samples[0].capacity_ah - samples[0].current_a * samples[0].time_s / 3600.0
    delivered_ah = start_ah - samples[-1].capacity_ah
    return [1.0 - (start_ah - s.capacity_ah) / delivered_ah for s in samples]


def discharge_rmse(params, samples, excluded_end_soc=0.0):
    """Voltage RMSE (V) of the model over a measured discharge from full, at the
    measured ambient, leaving out the run's last ``excluded_end_soc``.
    Returns (rmse, number of samples compared)."""
    test = replace(params, ambient_temperature_c=samples[0].temperature_c)
    _, simulated, _ = simulate(test, samples, state_of_charge=1.0)
    kept = [(v, s.voltage_v) for v, s, soc in zip(simulated, samples, run_soc(samples))
            if soc >= excluded_end_soc]
    return rmse([k[0] for k in kept], [k[1] for k in kept]), len(kept)


def charge_time_error(params, rest, run):
    """Relative error of the model's time to full against one measured charge
    (see charge_runs), starting at the SOC of the rest voltage before it."""
    test = replace(params, ambient_temperature_c=rest.temperature_c)
    start_soc = OcvCurve(test.ocv_soc, test.ocv_voltage_v).soc(rest.voltage_v)
    simulated_s = time_to_full(BatteryModel(test, state_of_charge=start_soc, mode=Mode.IDLE))
    return simulated_s / (run[-1].time_s - rest.time_s) - 1.0
