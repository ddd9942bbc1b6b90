"""The equivalent circuit of core/battery_model.py as arrays over a log (no ROS), for fitting.

For given capacity, starting SOC and time constants the cell voltage is linear in the OCV (its offset,
or its values at knots), R0, R1 and R_fast: V = OCV(soc) + R0 f0 S i + R1 x1 + R_fast x_fast, where
x1 and x_fast are the current through each RC pair's memory, f the SOC factor tables and charge factors
and S the Arrhenius scale at the model's temperature. So the fit searches a handful of numbers and
solves the rest by least squares. A sample's current is what flowed over the interval after it, as
battery_replay holds each row's current until the next row: the voltage at a sample answers the
previous sample's current (one convention, the replay's, for the fit, the heat and the counted charge).
"""
from dataclasses import dataclass

import numpy as np

_KELVIN = 273.15
#: within one block of rc_filter the decay is at most exp(-BLOCK_DECAY): no underflow, no precision loss
BLOCK_DECAY = 20.0


def rc_filter(u, decay, y0=0.0):
    """y[k] = decay[k] y[k-1] + (1 - decay[k]) u[k] with y[-1] = y0, vectorised (decay in (0, 1])."""
    u = np.asarray(u, dtype=float)
    decay = np.broadcast_to(np.asarray(decay, dtype=float), u.shape)
    log_decay = np.log(np.maximum(decay, 1e-300))
    y = np.empty_like(u)
    start, previous, n = 0, y0, len(u)
    cumulative = np.cumsum(log_decay)
    while start < n:
        base = cumulative[start - 1] if start else 0.0
        end = int(np.searchsorted(-cumulative, -(base - BLOCK_DECAY), side='right'))
        end = max(end, start + 1)
        level = cumulative[start:end] - base           # <= 0, >= -BLOCK_DECAY (but the block's first)
        gain = (1.0 - decay[start:end]) * u[start:end] * np.exp(-level)
        y[start:end] = np.exp(level) * (previous + np.cumsum(gain))
        previous = y[end - 1]
        start = end
    return y


@dataclass
class Chemistry:
    """The cell preset's shape: OCV branches, resistance tables, charge factors, hysteresis, heat."""

    params: object

    def __post_init__(self):
        p = self.params
        self.soc_points = np.asarray(p.ocv_soc, dtype=float)
        self.ocv = np.asarray(p.ocv_voltage_v, dtype=float)
        self.gap = (np.asarray(p.ocv_charge_voltage_v, dtype=float) - self.ocv) if p.ocv_charge_voltage_v \
            else np.zeros_like(self.ocv)
        self.table_soc = np.asarray(p.resistance_soc, dtype=float) if p.resistance_soc else None
        self.factors = [np.asarray(t, dtype=float) if len(t) else None
                        for t in (p.r0_soc_factor, p.r1_soc_factor, p.r_fast_soc_factor)]
        self.charge_factors = (p.r0_charge_factor, p.r1_charge_factor, p.r_fast_charge_factor)

    def factor(self, which, soc, charging, use_tables):
        """The SOC factor times the direction factor of resistance ``which`` (0 r0, 1 r1, 2 r_fast)."""
        direction = np.where(charging, self.charge_factors[which], 1.0)
        if not use_tables or self.table_soc is None or self.factors[which] is None:
            return direction
        return direction * np.interp(soc, self.table_soc, self.factors[which])

    def ocv_at(self, soc, weight):
        """The OCV of the preset's shape at ``soc`` between its branches (weight 0 discharge, 1 charge)."""
        return np.interp(soc, self.soc_points, self.ocv) + weight * np.interp(soc, self.soc_points, self.gap)

    def arrhenius(self, temperature_c):
        p = self.params
        if not p.arrhenius_temperature_k:
            return np.ones_like(temperature_c)
        return np.exp(p.arrhenius_temperature_k * (1.0 / (temperature_c + _KELVIN)
                                                   - 1.0 / (p.reference_temperature_c + _KELVIN)))


@dataclass
class LogArrays:
    """What does not change while the fit searches: per-interval times, the cell current, the
    hysteresis weight (0 discharge branch .. 1 charge branch) for one parallel count."""

    dt: np.ndarray
    cell_current: np.ndarray
    charging: np.ndarray
    weight: np.ndarray
    cell_voltage: np.ndarray


def flowing_current(current_a):
    """The current over the interval before each sample: the previous sample's (battery_replay holds a
    row's current until the next row; none before the first)."""
    return np.concatenate([[0.0], np.asarray(current_a, dtype=float)[:-1]])


def counted_charge_ah(log):
    """The charge counted to each sample, Ah (the replay's convention), from 0 at the first."""
    return np.concatenate([[0.0], np.cumsum(log.current_a[:-1] * np.diff(log.time_s))]) / 3600.0


def log_arrays(log, chemistry, cells_series, cells_parallel):
    dt = np.concatenate([[0.0], np.diff(log.time_s)])
    cell_current = flowing_current(log.current_a) / cells_parallel
    charging = cell_current > 0.0
    target = np.where(cell_current > 0, 1.0, np.where(cell_current < 0, -1.0, 0.0))
    rate = np.abs(cell_current) * dt / (3600.0 * chemistry.params.hysteresis_ah)
    decay = np.where(target == 0.0, 1.0, np.exp(-rate))
    # h moves towards +-1 while current flows and stays where it is at rest
    hysteresis = rc_filter(np.where(target == 0.0, 0.0, target), decay, y0=-1.0)
    return LogArrays(dt=dt, cell_current=cell_current, charging=charging, weight=0.5 * (1.0 + hysteresis),
                     cell_voltage=log.voltage_v / cells_series)


def state_of_charge(arrays, capacity_cell_ah, soc0, efficiency):
    """The SOC at each sample by coulomb counting from ``soc0`` (clamped to 0..1, as the model does)."""
    i = arrays.cell_current
    counted = np.where(i > 0, efficiency * i, i) * arrays.dt / (3600.0 * capacity_cell_ah)
    return np.clip(soc0 + np.cumsum(counted), 0.0, 1.0)


def thermal(arrays, heat_w, ambient_c, initial_c, heat_capacity, transfer):
    """The cell temperature of the model's lumped thermal mass under ``heat_w`` per cell."""
    decay = np.exp(-arrays.dt * transfer / heat_capacity)
    return rc_filter(ambient_c + heat_w / transfer, decay, y0=initial_c)


def regressors(arrays, soc, scale, chemistry, tau1_s, tau_fast_s, use_tables):
    """(x0, x1, x_fast): the voltage per ohm of R0, R1 and R_fast at each sample, per cell."""
    i = arrays.cell_current
    charging = arrays.charging
    x0 = chemistry.factor(0, soc, charging, use_tables) * scale * i
    x1 = rc_filter(chemistry.factor(1, soc, charging, use_tables) * scale * i, np.exp(-arrays.dt / tau1_s))
    xf = rc_filter(chemistry.factor(2, soc, charging, use_tables) * scale * i, np.exp(-arrays.dt / tau_fast_s))
    return x0, x1, xf


def hat_basis(soc, knots):
    """Piecewise-linear interpolation weights of ``soc`` on ``knots`` (one column per knot)."""
    soc = np.clip(soc, knots[0], knots[-1])
    index = np.clip(np.searchsorted(knots, soc, side='right') - 1, 0, len(knots) - 2)
    fraction = (soc - knots[index]) / (knots[index + 1] - knots[index])
    basis = np.zeros((len(soc), len(knots)))
    rows = np.arange(len(soc))
    basis[rows, index] = 1.0 - fraction
    basis[rows, index + 1] += fraction
    return basis
