"""What battery_fit says (no ROS): the voltage figures through the real model, as battery_replay computes
them (each log's current replayed from its starting SOC with the fitted config), and the report text."""
import math
from dataclasses import dataclass

import numpy as np

from battery_simulator.core.fit.conventions import as_logged
from battery_simulator.core.replay import replay

PROFILE_COLUMNS = ('time', 'current', 'voltage')


@dataclass
class Figures:
    """Per log: the model's voltage (pack V) at each sample; RMSEs in pack volts on the fitted and the
    held-out samples (NaN: none), over all logs and per log."""

    model_voltage: list
    fit_rmse_v: float
    holdout_rmse_v: float
    per_log: list


def replay_profile(log):
    """battery_replay's profile of a log: (time, 'current', A) per sample, the current in ROS's sign."""
    return [(float(t), 'current', float(i)) for t, i in zip(log.time_s, log.current_a)]


def figures(result):
    voltages, fit_errors, held_errors, per_log = [], [], [], []
    for log, soc, mask, left_out in zip(result.logs, result.initial_soc, result.fit_masks, _left_out(result)):
        # the log's current in the replay's own convention (FitLog.current_a): the same as its logged current
        # replayed with the config's profile_current_timing
        rows = replay(result.params, replay_profile(log), state_of_charge=min(max(soc, 0.0), 1.0),
                      timing='until_next_row')
        model = np.array([float(row[1]) for row in rows])
        error = model - log.voltage_v
        voltages.append(model)
        fit_errors.append(error[mask & ~left_out])
        held_errors.append(error[~mask])
        per_log.append((_rmse(error[mask & ~left_out]), _rmse(error[~mask])))
    return Figures(voltages, _rmse(np.concatenate(fit_errors)), _rmse(np.concatenate(held_errors)), per_log)


def replayed_rmse(result, most_samples):
    """The voltage RMSE (pack V) of the fitted samples of ``result``'s logs replayed with its parameters, each
    log thinned to at most ``most_samples`` (its current the mean over each new interval: the charge kept)."""
    errors = []
    for log, soc, mask, left_out in zip(result.logs, result.initial_soc, result.fit_masks, _left_out(result)):
        end = int(np.flatnonzero(mask)[-1]) + 1
        step = max(1, end // most_samples)
        t = log.time_s[:end]
        charge = np.concatenate([[0.0], np.cumsum(log.current_a[:end - 1] * np.diff(t))])[::step]
        times = t[::step]
        span = np.diff(times)
        current = np.concatenate([np.diff(charge) / np.where(span > 0, span, 1.0), [log.current_a[end - 1]]])
        profile = [(float(a), 'current', float(b)) for a, b in zip(times, current)]
        rows = replay(result.params, profile, state_of_charge=min(max(soc, 0.0), 1.0), timing='until_next_row')
        model = np.array([float(row[1]) for row in rows])
        errors.append((model - log.voltage_v[:end:step])[~left_out[:end:step]])
    return _rmse(np.concatenate(errors))


def _left_out(result):
    """Per log: the samples of the fitted part the fit left out (a filled gap of the source), none if not said."""
    return result.left_out or [np.zeros(len(log.time_s), dtype=bool) for log in result.logs]


def _rmse(values):
    return float(np.sqrt(np.mean(np.square(values)))) if len(values) else math.nan


def _figure(volts, cells_series):
    if not math.isfinite(volts):
        return 'none (nothing held out)'
    return '%6.1f mV per cell (%.3f V for the pack)' % (1000.0 * volts / cells_series, volts)


def report_text(result, numbers, output, holdout, profiles=None):
    p = result.params
    lines = ['battery_fit: %d log%s fitted over the %s preset: %d cells in series x %d in parallel, %.3g Ah, '
             '%.4g ohm (pack)' % (len(result.logs), 's' * (len(result.logs) > 1), result.chemistry, p.cells_series,
                                  p.cells_parallel, p.design_capacity_ah, p.r0_ohm * p.cells_series / p.cells_parallel)]
    for index, (log, soc) in enumerate(zip(result.logs, result.initial_soc)):
        span = log.time_s[-1] - log.time_s[0]
        lines.append('log %s: %d samples over %.2f h (%s), starts at SOC %.3f' % (
            log.name, len(log.time_s), span / 3600.0, log.source, soc))
        lines.extend('  ' + note for note in log.notes)
        fit_v, held_v = numbers.per_log[index]
        lines.append('  voltage RMSE: fitted %s, held out %s' % (_figure(fit_v, p.cells_series).strip(),
                                                                 _figure(held_v, p.cells_series).strip()))
    lines.append('voltage RMSE, the model replaying the logs\' current (as battery_replay does):')
    lines.append('  fitted part:   %s' % _figure(numbers.fit_rmse_v, p.cells_series))
    lines.append('  held-out part: %s   (the last %g %% of each log)' % (_figure(numbers.holdout_rmse_v, p.cells_series),
                                                                      100.0 * holdout))
    lines.append('fitted values (1 sigma from the fit\'s residuals):')
    for name, fitted in result.fitted.items():
        value = fitted.value
        if isinstance(value, float):
            value = '%.5g' % value
        sigma = ' +- %.2g' % fitted.uncertainty if fitted.uncertainty is not None and fitted.uncertainty == \
            fitted.uncertainty else ''
        lines.append('  %-30s %s%s   (%s)' % (name, value, sigma, fitted.source))
    if result.kept:
        lines.append('kept from the %s preset:' % result.chemistry)
        for name, why in result.kept.items():
            lines.append('  %-30s %s' % (name, why))
    if result.warnings:
        lines.append('warnings:')
        lines.extend('  ' + warning for warning in result.warnings)
    lines.append('config: %s' % output)
    for index, soc in enumerate(result.initial_soc):
        profile = profiles[index] if profiles else 'PROFILE.csv'
        lines.append('replay: battery_replay.py %s --config %s --soc %.4f' % (profile, output, soc))
    return '\n'.join(lines) + '\n'


def write_profile(path, log):
    """A log's current and voltage as battery_replay's profile CSV (the current in ROS's sign)."""
    with open(path, 'w', encoding='utf-8') as stream:
        stream.write(','.join(PROFILE_COLUMNS) + '\n')
        for t, i, v in zip(log.time_s, as_logged(log), log.voltage_v):
            stream.write('%.6g,%.6g,%.6g\n' % (t, i, v))
