"""Measured cell tests (cycler CSV exports) and the model run against them (no rospy).

Used to fit the LG HG2 preset (tools/fit_lg_hg2.py) and to validate the model
(test/core/test_measured_data.py). The format is the one in test/data/lg_hg2/.
"""
import csv
import math
from collections import namedtuple
from dataclasses import replace

from battery_simulator.core.battery_states import Mode, Status
from battery_simulator.core.cell_tables import OcvCurve
from battery_simulator.core.pack import make_model

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
    model = make_model(params, state_of_charge=state_of_charge, mode=mode or Mode.IDLE)
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
    simulated_s = time_to_full(make_model(test, state_of_charge=start_soc, mode=Mode.IDLE))
    return simulated_s / (run[-1].time_s - rest.time_s) - 1.0


def measured_charge_phases(rest, run):
    """(CC seconds, CV seconds) of a measured CC-CV charge (see charge_runs).

    The CC phase ends where the voltage of its last sample, rising at the slope
    of its last two, reaches the CV voltage (the log has a row a minute).
    """
    cc_current = run[0].current_a
    last = max(k for k, s in enumerate(run) if s.current_a >= 0.995 * cc_current)
    cv_voltage = max(s.voltage_v for s in run)
    end = run[last]
    before = run[last - 1] if last > 0 else rest
    after = run[min(last + 1, len(run) - 1)]
    slope = (end.voltage_v - before.voltage_v) / (end.time_s - before.time_s)
    cc_end_s = end.time_s + (cv_voltage - end.voltage_v) / slope if slope > 0.0 else end.time_s
    cc_end_s = min(max(cc_end_s, end.time_s), after.time_s)
    return cc_end_s - rest.time_s, run[-1].time_s - cc_end_s


def simulated_charge(params, rest, run, max_step_s=2.0):
    """The model's own CC-CV charge against a measured one (see charge_runs): at
    the run's CC current and end current and the rest's temperature, from the SOC
    the rest voltage gives on the OCV table.

    Returns (CC seconds, CV seconds or None if it never ends, [(voltage V, current A)
    at each sample's time])."""
    test = replace(params, ambient_temperature_c=rest.temperature_c, charge_current_a=run[0].current_a,
                   termination_current_a=run[-1].current_a, charger_holds_full=False)   # a cycler stops at its end
    start_soc = OcvCurve(test.ocv_soc, test.ocv_voltage_v).soc(rest.voltage_v)
    model = make_model(test, state_of_charge=start_soc, mode=Mode.CHARGE)
    cc_current = test.charge_current_a
    elapsed, cc_end_s, full_s, trace = 0.0, None, None, []
    for sample in run + [sample._replace(time_s=sample.time_s + 7200.0) for sample in run[-1:]]:
        remaining = sample.time_s - rest.time_s - elapsed
        steps = max(1, int(math.ceil(remaining / max_step_s)))
        for _ in range(steps):
            model.step(remaining / steps)
            elapsed += remaining / steps
            if cc_end_s is None and model.current_a < 0.999 * cc_current:
                cc_end_s = elapsed - remaining / steps / 2.0
            if full_s is None and model.status is Status.FULL:
                full_s = elapsed - remaining / steps / 2.0
        trace.append((model.voltage_v, model.current_a))
    cc_end_s = elapsed if cc_end_s is None else cc_end_s
    return cc_end_s, None if full_s is None else full_s - cc_end_s, trace[:-1]


def charge_phase_errors(params, rest, run):
    """Relative errors of the model's CC and CV phase durations against one measured charge."""
    measured_cc, measured_cv = measured_charge_phases(rest, run)
    cc_s, cv_s, _ = simulated_charge(params, rest, run)
    return cc_s / measured_cc - 1.0, (math.inf if cv_s is None else cv_s / measured_cv - 1.0)
