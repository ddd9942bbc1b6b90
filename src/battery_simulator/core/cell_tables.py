"""A cell's tables and their look-ups (no rospy): the piecewise-linear OCV(SOC) curve with its inverse and
slope, and the resistances by SOC and current direction. core/battery_model.py steps the pack on them."""
from bisect import bisect_right


class OcvCurve:
    """Piecewise-linear OCV(SOC) with its inverse and slope."""

    def __init__(self, soc_points, voltages):
        self.soc_points = tuple(soc_points)
        self.voltages = tuple(voltages)
        self._slopes = tuple((v1 - v0) / (s1 - s0) for s0, s1, v0, v1 in zip(
            self.soc_points, self.soc_points[1:], self.voltages, self.voltages[1:]))
        self._last = len(self._slopes) - 1

    def _segment(self, soc):
        k = bisect_right(self.soc_points, soc) - 1
        return 0 if k < 0 else (k if k < self._last else self._last)

    def voltage(self, soc):
        """OCV at ``soc`` (clamped to the table), V."""
        k = self._segment(soc)
        soc = 0.0 if soc < 0.0 else (1.0 if soc > 1.0 else soc)
        return self.voltages[k] + self._slopes[k] * (soc - self.soc_points[k])

    def slope(self, soc):
        """dOCV/dSOC at ``soc``, V per unit SOC."""
        return self._slopes[self._segment(soc)]

    def slopes_beside(self, other, soc):
        """(``other``'s slope, this curve's voltage, its slope) at ``soc``, with one table look-up."""
        k = self._segment(soc)
        offset = (0.0 if soc < 0.0 else (1.0 if soc > 1.0 else soc)) - self.soc_points[k]
        return other._slopes[k], self.voltages[k] + self._slopes[k] * offset, self._slopes[k]

    def voltage_beside(self, other, soc, weight):
        """``other``'s voltage plus ``weight`` times this curve's at ``soc`` (one table look-up: the
        two share their SOC points)."""
        k = self._segment(soc)
        offset = (0.0 if soc < 0.0 else (1.0 if soc > 1.0 else soc)) - self.soc_points[k]
        return (other.voltages[k] + other._slopes[k] * offset
                + weight * (self.voltages[k] + self._slopes[k] * offset))

    def soc(self, voltage):
        """The SOC whose OCV is ``voltage`` (clamped to 0..1)."""
        k = min(max(bisect_right(self.voltages, voltage) - 1, 0), self._last)
        soc = self.soc_points[k] + (voltage - self.voltages[k]) / self._slopes[k]
        return min(max(soc, 0.0), 1.0)


class ResistanceTable:
    """R0, R1 and R_fast per cell at the reference temperature, by SOC and direction."""

    def __init__(self, params):
        p = params
        self.discharge = (p.r0_ohm, p.r1_ohm, p.r_fast_ohm)
        self.charge = (p.r0_ohm * p.r0_charge_factor, p.r1_ohm * p.r1_charge_factor,
                       p.r_fast_ohm * p.r_fast_charge_factor)
        #: None when no resistance depends on SOC
        self.soc_points = tuple(p.resistance_soc) if p.resistance_soc else None
        if self.soc_points is None:
            return
        ones = (1.0,) * len(self.soc_points)
        factors = [tuple(t) or ones for t in (p.r0_soc_factor, p.r1_soc_factor, p.r_fast_soc_factor)]
        # Per segment: (start SOC, end SOC, the three factors at the start, their three slopes).
        self._segments = tuple(
            (s0, s1) + tuple(f[k] for f in factors) + tuple((f[k + 1] - f[k]) / (s1 - s0) for f in factors)
            for k, (s0, s1) in enumerate(zip(self.soc_points, self.soc_points[1:])))
        self._last = len(self._segments) - 1

    def at(self, soc, charging):
        """(r0, r1, r_fast) in ohm at ``soc`` for a charging or discharging current."""
        return self.along(soc, 0.0, (0.0, 0.0, 0.0), charging)

    def along(self, soc, soc_change, fractions, charging):
        """(r0, r1, r_fast) in ohm, each at ``soc`` plus its fraction of ``soc_change``."""
        base = self.charge if charging else self.discharge
        if self.soc_points is None:
            return base
        soc = 0.0 if soc < 0.0 else (1.0 if soc > 1.0 else soc)
        start, end, f0, f1, f2, s0, s1, s2 = self._segment(soc)
        if not start <= soc + soc_change <= end:   # the step leaves its segment: one look-up each
            return tuple(b * self._factor(k, soc + f * soc_change) for k, (b, f) in enumerate(zip(base, fractions)))
        offset = soc - start
        return (base[0] * (f0 + s0 * (offset + fractions[0] * soc_change)),
                base[1] * (f1 + s1 * (offset + fractions[1] * soc_change)),
                base[2] * (f2 + s2 * (offset + fractions[2] * soc_change)))

    def r0_at(self, soc, charging):
        """r0 alone, ohm (see at)."""
        r0 = self.charge[0] if charging else self.discharge[0]
        if self.soc_points is None:
            return r0
        return r0 * self._factor(0, soc)

    def _factor(self, which, soc):
        soc = 0.0 if soc < 0.0 else (1.0 if soc > 1.0 else soc)
        segment = self._segment(soc)
        return segment[2 + which] + segment[5 + which] * (soc - segment[0])

    def _segment(self, soc):
        k = bisect_right(self.soc_points, soc) - 1
        return self._segments[k if k < self._last else self._last]


