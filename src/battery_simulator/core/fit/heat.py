"""The heat (no ROS): ambient, heat capacity and transfer fitted to the logged temperature under the electrical
fit's heat, and the temperature the model will have over a log."""
import math

import numpy as np

from battery_simulator.core.fit import FitError, Fitted
from battery_simulator.core.fit.circuit import flowing_current, log_arrays, thermal
from battery_simulator.core.fit.electrical import jacobian_sigmas

#: the fitted ambient temperature is used when its uncertainty is below this, K (else the logged median)
AMBIENT_SIGMA_K = 5.0


def _cell_heat(log, cells_parallel, electrical, scale):
    """The heat of one cell, W: the current through it (the replay's convention) squared times its resistance
    (the electrical fit's, per cell of its own parallel count: a cell of ``cells_parallel`` has Np / Np' times)."""
    i = flowing_current(log.current_a) / cells_parallel
    r = sum(electrical.coefficients[name][0] for name in ('r0_ohm', 'r1_ohm', 'r_fast_ohm'))
    return i * i * r * (cells_parallel / electrical.cells_parallel) * scale


def fit_thermal(logs, masks, chemistry, cells_parallel, electrical, fitted, kept, warnings):
    """Ambient, heat capacity and transfer from the logged temperature (when it moves)."""
    from scipy.optimize import least_squares
    p = chemistry.params
    logged = [log for log in logs if log.temperature_c is not None]
    changes = {}
    heat = {'ambient': p.ambient_temperature_c, 'capacity': p.cell_heat_capacity_j_per_k,
            'transfer': p.cell_heat_transfer_w_per_k, 'changes': changes}
    if not logged:
        for name in ('ambient_temperature_c', 'cell_heat_capacity_j_per_k', 'cell_heat_transfer_w_per_k'):
            kept[name] = 'no temperature in the logs'
        return heat
    first = float(logged[0].temperature_c[0])
    changes['initial_temperature_c'] = float('%.3g' % first)
    fitted['initial_temperature_c'] = Fitted(changes['initial_temperature_c'], 'the first log\'s first temperature')
    spread = max(float(np.ptp(log.temperature_c)) for log in logged)
    if spread < 1.0:
        changes['ambient_temperature_c'] = float('%.3g' % np.median(np.concatenate([log.temperature_c for log in logged])))
        fitted['ambient_temperature_c'] = Fitted(changes['ambient_temperature_c'], 'the logged temperature '
                                                 '(it moves less than 1 K: the heat figures kept)')
        heat['ambient'] = changes['ambient_temperature_c']
        return heat
    pairs = [(log, mask, log_arrays(log, chemistry, 1, cells_parallel)) for log, mask in zip(logs, masks)
             if log.temperature_c is not None]

    def residuals(z):
        out = []
        for log, mask, arrays in pairs:
            cell_heat = _cell_heat(log, cells_parallel, electrical, chemistry.arrhenius(log.temperature_c))
            model = thermal(arrays, cell_heat, z[0], float(log.temperature_c[0]), math.exp(z[1]), math.exp(z[2]))
            out.append((model - log.temperature_c)[mask])
        return np.concatenate(out)
    z0 = [min(first, float(np.min(logged[0].temperature_c))), math.log(p.cell_heat_capacity_j_per_k),
          math.log(p.cell_heat_transfer_w_per_k)]
    solution = least_squares(residuals, z0, bounds=([-40, math.log(0.1), math.log(1e-4)], [90, math.log(1e6), math.log(1e3)]),
                             x_scale='jac', max_nfev=100)
    rmse = float(np.sqrt(np.mean(solution.fun ** 2)))
    sigmas = jacobian_sigmas(solution, rmse)
    heat.update(ambient=float(solution.x[0]), capacity=math.exp(solution.x[1]), transfer=math.exp(solution.x[2]))
    if not (sigmas[0] < AMBIENT_SIGMA_K and sigmas[2] < 1.0):   # also NaN: the logs do not tell the ambient
        ambient = float(np.median(np.concatenate([log.temperature_c[mask] for log, mask, _ in pairs])))
        transfer = math.log(p.cell_heat_transfer_w_per_k)
        solution = least_squares(lambda z: residuals([ambient, z[0], transfer]), [solution.x[1]],
                                 bounds=([math.log(0.1)], [math.log(1e6)]), x_scale='jac', max_nfev=50)
        rmse = float(np.sqrt(np.mean(solution.fun ** 2)))
        capacity_sigma = jacobian_sigmas(solution, rmse)[0]
        kept['cell_heat_transfer_w_per_k'] = ('the logged temperature does not tell the transfer to ambient from '
                                              'the ambient (the fit gave %.3g +- %.2g degC): the ambient set to the '
                                              'median logged temperature' % (heat['ambient'], sigmas[0]))
        heat.update(ambient=ambient, capacity=math.exp(solution.x[0]), transfer=p.cell_heat_transfer_w_per_k)
        sigmas = [0.0, capacity_sigma, math.inf]
    for name, value, sigma in (('ambient_temperature_c', heat['ambient'], sigmas[0]),
                               ('cell_heat_capacity_j_per_k', heat['capacity'], heat['capacity'] * sigmas[1]),
                               ('cell_heat_transfer_w_per_k', heat['transfer'], heat['transfer'] * sigmas[2])):
        if name in kept:
            continue
        if name != 'ambient_temperature_c' and not sigma < value:   # also NaN
            kept[name] = 'the fit gave %.3g +- %.2g: its uncertainty exceeds its value' % (value, sigma)
            heat['capacity' if 'capacity' in name else 'transfer'] = getattr(p, name)
            continue
        changes[name] = float('%.4g' % value)
        fitted[name] = Fitted(changes[name], 'the logged temperature under the fitted heat (RMSE %.2f K)' % rmse,
                              float(sigma))
    heat['ambient'] = changes['ambient_temperature_c']
    if not -60 <= changes['ambient_temperature_c'] <= 100:
        raise FitError('the logged temperature gives an ambient of %g degC: outside [-60, 100]'
                       % changes['ambient_temperature_c'])
    return heat


def model_temperature(log, chemistry, cells_parallel, electrical, heat):
    """The temperature the model will have (its thermal mass from the first logged temperature)."""
    arrays = log_arrays(log, chemistry, 1, cells_parallel)
    start = float(log.temperature_c[0]) if log.temperature_c is not None else heat['ambient']
    if log.temperature_c is None and 'initial_temperature_c' in heat['changes']:
        start = heat['changes']['initial_temperature_c']
    temperature = np.full(len(log.time_s), start)
    for _ in range(2):
        cell_heat = _cell_heat(log, cells_parallel, electrical, chemistry.arrhenius(temperature))
        temperature = thermal(arrays, cell_heat, heat['ambient'], start, heat['capacity'], heat['transfer'])
    return temperature
