"""The loads and the charger (no ROS): the idle and motion loads from the battery current against cmd_vel, the
charger's CC current and CV voltage from the charges, and the datasheet currents raised to what the logs show."""
import itertools
import math

import numpy as np

from battery_simulator.core.fit import Fitted
from battery_simulator.core.fit.known import CHARGE_MIN_S, runs
from battery_simulator.core.parameter_rules import CHARGE_VOLTAGE_ABOVE_FULL_V

#: the datasheet currents are raised to this many times the fitted part's largest
LIMIT_MARGIN = 2.0


def fit_loads(logs, masks, cells_series, chemistry_params, fitted, kept):
    """Idle current / power and the motion coefficients from the discharge samples:
    -I = I_idle + (P_idle + drive |v| + turn |w|) / V (the model's load equation)."""
    changes = {}
    has_motion = any(log.speed_mean is not None for log in logs)
    best = None
    for which in (('speed_mean', 'turn_mean'), ('speed_now', 'turn_now')) if has_motion else ((None, None),):
        columns, target = [[], [], [], []], []
        for log, mask in zip(logs, masks):
            use = mask & (log.current_a < 0)
            use[0] = False
            volts = log.voltage_v[use]
            columns[0].append(np.ones(use.sum()))
            columns[1].append(1.0 / volts)
            speed = getattr(log, which[0]) if which[0] and getattr(log, which[0]) is not None else np.zeros(len(use))
            turn = getattr(log, which[1]) if which[1] and getattr(log, which[1]) is not None else np.zeros(len(use))
            columns[2].append(speed[use] / volts)
            columns[3].append(turn[use] / volts)
            target.append(-log.current_a[use])
        design = np.column_stack([np.concatenate(c) for c in columns])
        target = np.concatenate(target)
        if len(target) < 10:
            break
        usable = [j for j in range(4) if np.ptp(design[:, j]) > 0 or j < 2]
        for size in range(1, len(usable) + 1):
            for subset in itertools.combinations(usable, size):
                if (0 in subset) == (1 in subset):   # one idle term: a current or a power
                    continue
                values, *_ = np.linalg.lstsq(design[:, subset], target, rcond=None)
                if (values < 0).any():
                    continue
                residual = target - design[:, subset] @ values
                score = float(residual @ residual) * (1.0 + 2.0 * size / len(target))
                if best is None or score < best[0]:
                    best = (score, subset, values, design, target, residual)
    if best is None:
        kept['load_current_a'] = 'no discharge samples to read the idle load from'
        return changes
    _, subset, values, design, target, residual = best
    dof = max(1, len(target) - len(subset))
    covariance = np.linalg.pinv(design[:, subset].T @ design[:, subset]) * float(residual @ residual) / dof
    sigma = np.sqrt(np.maximum(np.diag(covariance), 0.0))
    found = {j: (float(values[k]), float(sigma[k])) for k, j in enumerate(subset)}
    names = ('load_current_a', 'load_power_w', 'drive_power_w_per_mps', 'turn_power_w_per_radps')
    sources = ('the battery current with the robot on', 'the battery power with the robot on',
               'battery power against the commanded speed', 'battery power against the commanded turn rate')
    for j, name in enumerate(names):
        if j in found:
            changes[name] = float('%.4g' % found[j][0])
            fitted[name] = Fitted(changes[name], sources[j], found[j][1])
        elif j < 2:
            changes[name] = 0.0
            fitted[name] = Fitted(0.0, 'one idle term, %s (it fits the standstill draw better)' % names[1 - j])
        elif not has_motion:
            kept[name] = 'no motion topic (cmd_vel / odometry) or linear_x / angular_z columns in the logs'
        else:
            changes[name] = 0.0
            fitted[name] = Fitted(0.0, 'the battery power does not grow with it')
    return changes


def fit_charger(logs, masks, cells_series, cells_parallel, chemistry_params, changes, fitted, kept):
    """The charger from the charges in the fitted part of the logs."""
    p = chemistry_params
    # a charge: more than C/40 (a sensor's noise at rest is not one)
    threshold = max(0.05, changes['cell_capacity_ah'] * cells_parallel / 40.0)
    # a charge lasts (a vehicle's regeneration, pulses of charge current while it drives, is not one)
    masks = [_lasting(log.time_s, mask & (log.current_a > threshold), CHARGE_MIN_S) for log, mask in zip(logs, masks)]
    charging = [log.current_a[mask & (log.current_a > threshold)] for log, mask in zip(logs, masks)]
    currents = np.concatenate(charging)
    result = {}
    if len(currents) < 10:
        kept['charge_current_a'] = 'no charge in the logs: the preset\'s C-rate at the fitted capacity'
        kept['cell_charge_voltage_v'] = 'no charge in the logs: the preset\'s, within the fitted OCV table'
        result['charge_current_a'] = float('%.4g' % (p.charge_current_a / p.design_capacity_ah
                                                     * changes['cell_capacity_ah'] * cells_parallel))
        return result
    current = float(np.percentile(currents, 90))
    result['charge_current_a'] = float('%.4g' % current)
    fitted['charge_current_a'] = Fitted(result['charge_current_a'], 'the charge\'s constant current (90th '
                                        'percentile of %d charging samples)' % len(currents),
                                        float(np.std(currents[currents > 0.8 * current])))
    top = max(float(np.max(log.voltage_v[mask & (log.current_a > threshold)]) if (mask & (log.current_a > threshold)).any()
                    else 0.0) for log, mask in zip(logs, masks)) / cells_series
    tapering = np.concatenate([c[c < 0.7 * current] for c in charging])
    if len(tapering) >= 5 and top > 0:
        # its highest voltage, within what the model takes (parameter_rules: at most CHARGE_VOLTAGE_ABOVE_FULL_V
        # above the OCV table's top)
        most = changes['ocv_voltage_v'][-1] + CHARGE_VOLTAGE_ABOVE_FULL_V
        limit = math.floor(1e4 * min(top, most)) / 1e4
        if limit > changes['cell_cutoff_voltage_v']:
            result['cell_charge_voltage_v'] = limit
            highest = 'its highest cell voltage' if top <= most else (
                'its highest cell voltage %.4g V, cut to %g V above the OCV table\'s top, the most the model takes'
                % (top, CHARGE_VOLTAGE_ABOVE_FULL_V))
            fitted['cell_charge_voltage_v'] = Fitted(result['cell_charge_voltage_v'], 'the charge\'s constant '
                                                     'voltage (%s, %d samples tapering)' % (highest, len(tapering)))
        end = float(np.min(tapering))
        if 0 < end < current:
            result['termination_current_a'] = float('%.4g' % end)
            fitted['termination_current_a'] = Fitted(result['termination_current_a'], 'the end of the taper')
    else:
        kept['cell_charge_voltage_v'] = 'the charges in the logs do not reach constant voltage (no taper)'
    max_charge = p.cell_max_charge_current_a * cells_parallel
    if result['charge_current_a'] > max_charge:
        result['cell_max_charge_current_a'] = float('%.4g' % (1.2 * result['charge_current_a'] / cells_parallel))
    return result


def _lasting(time_s, flags, seconds):
    """``flags`` where they hold for at least ``seconds`` on end."""
    out = np.zeros(len(flags), dtype=bool)
    for start, stop in runs(flags):
        if time_s[stop - 1] - time_s[start] >= seconds:
            out[start:stop] = True
    return out


def current_limits(logs, masks, cells_series, cells_parallel, chemistry_params, changes, fitted):
    """The datasheet currents raised to what the fitted part shows (twice that: a later drive may ask for
    more), so the model never cuts the logged load off."""
    p = chemistry_params
    result = {}
    discharge = max(float(-np.min(log.current_a[mask])) for log, mask in zip(logs, masks)) / cells_parallel
    if discharge * LIMIT_MARGIN > p.cell_max_discharge_current_a:
        result['cell_max_discharge_current_a'] = float('%.4g' % (LIMIT_MARGIN * discharge))
        fitted['cell_max_discharge_current_a'] = Fitted(result['cell_max_discharge_current_a'],
                                                        'twice the fitted part\'s largest discharge current')
    charge = max(float(np.max(log.current_a[mask])) for log, mask in zip(logs, masks)) / cells_parallel
    limit = max(charge * LIMIT_MARGIN, changes.get('cell_max_charge_current_a', p.cell_max_charge_current_a),
                changes['charge_current_a'] / cells_parallel * 1.01)
    if limit > p.cell_max_charge_current_a:
        result['cell_max_charge_current_a'] = float('%.4g' % limit)
        fitted['cell_max_charge_current_a'] = Fitted(result['cell_max_charge_current_a'],
                                                     'twice the fitted part\'s largest charge current')
    load = changes.get('load_current_a', p.load_current_a)
    if load > result.get('cell_max_discharge_current_a', p.cell_max_discharge_current_a) * cells_parallel:
        result['cell_max_discharge_current_a'] = float('%.4g' % (1.2 * load / cells_parallel))
    return result
