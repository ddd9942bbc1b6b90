"""The OCV curve learned (no ROS): the OCV at knots over the SOC range the logs cover, beside the resistances,
kept where it predicts blocks of the fitted part held out in turn better than the preset's shape."""
import math

import numpy as np

from battery_simulator.core.fit.circuit import hat_basis, regressors, state_of_charge
from battery_simulator.core.fit.electrical import (TAU_FAST_BOUNDS, tau1_bounds, increasing, non_negative_lstsq,
                                                    small_lstsq)
from battery_simulator.core.fit.known import CHARGE_MIN_S, KNOWN_SPREAD, Known, runs

#: the OCV curve is learned where the logs cover at least LEARN_MIN_SOC_SPAN of the charge range and the
#: learned curve predicts each of CV_FOLDS blocks of the fitted part, held out in turn, better than the
#: preset's shape: its cross-validated RMSE below LEARN_GAIN times the shape's
LEARN_MIN_SOC_SPAN, LEARN_GAIN, CV_FOLDS = 0.05, 0.9, 5
#: the smoothness weights tried (the learned curvature's departure from the preset's, per knot, relative to
#: the data's weight): the one that cross-validates best is kept
SMOOTHNESS = (0.001, 0.003, 0.01, 0.03, 0.1, 0.3, 1.0, 3.0)
#: knots of a learned OCV curve: one per this much SOC, between these counts
LEARN_KNOT_SOC, LEARN_MIN_KNOTS, LEARN_MAX_KNOTS = 0.02, 4, 40
#: the coulombic efficiency (the charge a charge takes per charge a discharge gave back) is fitted beside the
#: curve where no logged percentage counts the charge and the fitted part both charges and discharges at least
#: EFFICIENCY_SPAN of the capacity each, for at least CHARGE_MIN_S (LG HG2 at C/20, Kollmeyer: 2.97 Ah charged
#: back after 2.78 Ah discharged, the same 4.19 V at rest before and after); within these bounds. A few hours of
#: charge place it weakly (that C/20 test's fitted part: its error falls steadily towards the lower bound, where
#: the search from the preset's value stops is what is written; docs/fit.md); cycles place it (0.97 found 0.966)
EFFICIENCY_SPAN, EFFICIENCY_BOUNDS = 0.05, (0.85, 1.0)


def fitted_soc_range(electrical, masks):
    """(lowest, highest) SOC the electrical fit puts the fitted samples at."""
    socs = np.concatenate([piece[1][mask] for piece, mask in zip(electrical.pieces, masks)])
    return float(np.min(socs)), float(np.max(socs))


def learn_curve(logs, masks, chemistry, temperatures, electrical, has_rest, known=None):
    """The OCV at knots over the covered SOC range, when the logs cover enough of it and the learned curve
    predicts blocks of the fitted part held out in turn better than the preset's shape (else None).
    Returns {knots, values, rmse_v, resistances, sigmas, gap, smoothness, cv: (preset, curve) RMSEs, taus}."""
    low, high = fitted_soc_range(electrical, masks)
    if high - low < LEARN_MIN_SOC_SPAN:
        return None
    count = int(np.clip(round((high - low) / LEARN_KNOT_SOC), LEARN_MIN_KNOTS, LEARN_MAX_KNOTS)) + 1
    knots = np.linspace(low, high, count)
    shape = np.interp(knots, chemistry.soc_points, chemistry.ocv)
    folds, voltage, gaps, preset_ocv, currents, hats = [], [], [], [], [], []
    for (a, soc, ocv, x0, x1, xf), mask in zip(electrical.pieces, masks):
        n = int(mask.sum())
        folds.append((np.arange(n) * CV_FOLDS) // n)   # contiguous blocks of each log's fitted part
        voltage.append(a.cell_voltage[mask])
        gaps.append((np.interp(soc, chemistry.soc_points, chemistry.gap) * a.weight)[mask])
        preset_ocv.append(ocv[mask])
        currents.append(np.column_stack([x0[mask], x1[mask], xf[mask]]))
        hats.append(hat_basis(soc[mask], knots))
    fold, voltage, gaps = np.concatenate(folds), np.concatenate(voltage), np.concatenate(gaps)
    resistive = np.vstack(currents)
    preset_design = np.column_stack(([np.ones(len(voltage))] if has_rest else []) + [resistive])
    preset_cv = _cross_validated(preset_design, voltage - np.concatenate(preset_ocv), fold, None, None)
    design = np.hstack([np.vstack(hats), resistive])
    scale = math.sqrt(len(voltage) / count)
    smooth = np.zeros((count - 2, design.shape[1]))
    for j in range(count - 2):
        smooth[j, j:j + 3] = (1.0, -2.0, 1.0)
    smooth_target = shape[:-2] - 2.0 * shape[1:-1] + shape[2:]
    best = None
    has_gap = bool(np.any(chemistry.gap))
    for gap in (True, False) if has_gap else (False,):
        target = voltage - gaps if gap else voltage
        for weight in SMOOTHNESS:
            error = _cross_validated(design, target, fold, weight * scale * smooth, weight * scale * smooth_target)
            if best is None or error < best[0]:
                best = (error, gap, weight)
    curve_cv, gap, weight = best
    if not curve_cv < LEARN_GAIN * preset_cv:
        return None
    # the time constants (and the later logs' starting SOC) again, with the curve beside the resistances
    from scipy.optimize import least_squares
    p = chemistry.params
    scales = [chemistry.arrhenius(temperature) for temperature in temperatures]
    arrays = [piece[0] for piece in electrical.pieces]

    known = known or Known()
    with_efficiency = known.soc0 is None and p.chemistry != 'lfp' and _charges_and_discharges(
        arrays, masks, electrical.capacity_ah / electrical.cells_parallel)

    def efficiency(z):
        return float(z[-1]) if with_efficiency else p.coulombic_efficiency

    def counted(k, z):   # per cell, Ah
        a = arrays[k]
        return np.cumsum(np.where(a.cell_current > 0, efficiency(z) * a.cell_current, a.cell_current) * a.dt) / 3600.0

    def starts(z):
        cell_capacity = math.exp(z[2]) / electrical.cells_parallel
        out = list(z[3:3 + len(arrays)])
        for k in range(len(arrays)):
            pin = known.start_pin(k)
            if pin is not None:   # SOC 1 at a full charge's end, or SOC 0 at a cut-off
                out[k] = min(1.0, max(0.0, (pin[0] == 'full') - counted(k, z)[pin[1]] / cell_capacity))
        return out

    def solve(z):
        cell_capacity = math.exp(z[2]) / electrical.cells_parallel
        soc0 = starts(z)
        rows, targets, pieces = [], [], []
        socs = []
        for k, a in enumerate(arrays):
            soc = state_of_charge(a, cell_capacity, soc0[k], efficiency(z))
            socs.append(soc[masks[k]])
        grid = np.linspace(min(float(np.min(s)) for s in socs), max(float(np.max(s)) for s in socs), count)
        if grid[-1] - grid[0] < 1e-6:
            grid = knots
        grid_shape = np.interp(grid, chemistry.soc_points, chemistry.ocv)
        for k, a in enumerate(arrays):
            m = masks[k]
            soc = state_of_charge(a, cell_capacity, soc0[k], efficiency(z))
            x0, x1, xf = regressors(a, soc, scales[k], chemistry, math.exp(z[0]), math.exp(z[1]),
                                    electrical.use_tables)
            pieces.append((a, soc, x0, x1, xf))
            rows.append(np.column_stack([hat_basis(soc[m], grid), x0[m], x1[m], xf[m]]))
            shift = np.interp(soc, chemistry.soc_points, chemistry.gap) * a.weight if gap else 0.0
            targets.append((a.cell_voltage - shift)[m])
        smooth_rows = weight * scale * smooth
        smooth_values = weight * scale * (grid_shape[:-2] - 2.0 * grid_shape[1:-1] + grid_shape[2:])
        return grid, np.vstack(rows + [smooth_rows]), np.concatenate(targets + [smooth_values]), len(
            np.concatenate(targets))

    def residuals(z):
        _, matrix, target, n = solve(z)
        return (target - matrix @ small_lstsq(matrix, target))[:n]

    # the SOC scale stays the one the logs fix (the logged percentage, a full charge and a cut-off): a learned
    # curve must not stretch it; without them the curve's smoothness places it (checked by replay after)
    capacity, soc0 = math.log(known.capacity_ah or electrical.capacity_ah), electrical.soc0
    if known.soc0 is not None:
        soc0 = known.soc0
    z0 = [math.log(electrical.tau1_s), math.log(electrical.tau_fast_s), capacity] + list(soc0)
    spread = KNOWN_SPREAD if known.capacity_ah is not None else math.log(3.0)   # else: the replay checks it
    slowest = tau1_bounds(logs, masks)
    low_bounds = [math.log(slowest[0]), math.log(TAU_FAST_BOUNDS[0]), capacity - spread] + [
        max(0.0, s - 0.02) if known.capacity_ah is not None else 0.0 for s in soc0]
    high_bounds = [math.log(slowest[1]), math.log(TAU_FAST_BOUNDS[1]), capacity + spread] + [
        min(1.0, s + 0.02) if known.capacity_ah is not None else 1.0 for s in soc0]
    if with_efficiency:
        z0.append(min(p.coulombic_efficiency, EFFICIENCY_BOUNDS[1]))
        low_bounds.append(EFFICIENCY_BOUNDS[0])
        high_bounds.append(EFFICIENCY_BOUNDS[1])
    z0 = np.clip(z0, np.asarray(low_bounds) + 1e-9, np.asarray(high_bounds) - 1e-9)
    solution = least_squares(residuals, z0, bounds=(low_bounds, high_bounds), x_scale='jac', diff_step=1e-4,
                             max_nfev=60)
    for weight in [w for w in SMOOTHNESS if w >= weight]:   # the smoothest needed for an increasing curve
        grid, matrix, target, n = solve(solution.x)
        solved = np.linalg.lstsq(matrix, target, rcond=None)[0]
        if np.all(np.diff(solved[:count]) > 0):
            break
    # else the smoothest, made increasing below (increasing): over a short span of a flat curve the noise can
    # bend it; the replay of the fitted part checks it against the preset's shape
    names = ['knot%d' % j for j in range(count)] + ['r0_ohm', 'r1_ohm', 'r_fast_ohm']
    values, sigmas, residual = non_negative_lstsq(matrix, target, ['offset'] * count + names[count:])
    resistances = [max(values[name], 0.0) for name in names[count:]]
    curve = solved[:count] if all(solved[count:] >= 0) else None
    if curve is None:   # the curve beside the non-negative resistances
        fixed = matrix[:, count:] @ np.asarray(resistances)
        curve = np.linalg.lstsq(matrix[:, :count], target - fixed, rcond=None)[0]
    fit_residual = (target - matrix @ np.concatenate([curve, resistances]))[:n]
    return {'knots': grid, 'values': increasing(curve), 'rmse_v': float(np.sqrt(np.mean(fit_residual ** 2))),
            'resistances': dict(zip(names[count:], resistances)),
            'sigmas': {name: sigmas.get(name) for name in names[count:]}, 'gap': gap, 'smoothness': weight,
            'cv': (preset_cv, curve_cv), 'tau1_s': math.exp(solution.x[0]), 'tau_fast_s': math.exp(solution.x[1]),
            'soc0': [float(v) for v in starts(solution.x)], 'capacity_ah': math.exp(solution.x[2]),
            'coulombic_efficiency': efficiency(solution.x) if with_efficiency else None}


def _charges_and_discharges(arrays, masks, cell_capacity_ah):
    """Whether the fitted parts hold a lasting charge and a lasting discharge, each of at least EFFICIENCY_SPAN
    of the capacity (the coulombic efficiency is then what the charge's voltage says beside the discharge's)."""
    found = {1: False, -1: False}
    for a, mask in zip(arrays, masks):
        i = a.cell_current
        threshold = max(0.02 * float(np.max(np.abs(i[mask]))), 1e-9)
        for sign in (1, -1):
            for start, stop in runs(mask & (sign * i > threshold)):
                seconds = float(np.sum(a.dt[start:stop]))
                charge = abs(float(np.sum(i[start:stop] * a.dt[start:stop]))) / 3600.0
                if seconds >= CHARGE_MIN_S and charge >= EFFICIENCY_SPAN * cell_capacity_ah:
                    found[sign] = True
    return found[1] and found[-1]


def _cross_validated(design, target, fold, smooth, smooth_target):
    """The RMSE of least squares predicting each fold from the others (a smoothness penalty beside)."""
    folds = int(fold.max()) + 1
    grams, moments, squares = [], [], []
    for f in range(folds):
        rows = fold == f
        grams.append(design[rows].T @ design[rows])
        moments.append(design[rows].T @ target[rows])
        squares.append(float(target[rows] @ target[rows]))
    gram, moment = sum(grams), sum(moments)
    if smooth is not None:
        gram_smooth, moment_smooth = smooth.T @ smooth, smooth.T @ smooth_target
    total = 0.0
    for f in range(folds):
        a, b = gram - grams[f], moment - moments[f]
        if smooth is not None:
            a, b = a + gram_smooth, b + moment_smooth
        values = np.linalg.lstsq(a, b, rcond=None)[0]
        total += max(squares[f] - 2.0 * values @ moments[f] + values @ grams[f] @ values, 0.0)
    return math.sqrt(total / len(target))
