"""An equivalent-circuit Li-ion pack model (no rospy).

Each cell is an open-circuit voltage source OCV(SOC) with a series resistance R0
and two RC pairs: a slow one (R1, tau1: solid-state diffusion) and an optional
fast one (R_fast, tau_fast: charge transfer), a lumped thermal mass and Coulomb
counting. The resistances may depend on SOC (factor tables) and on the
current's direction; the OCV may have a charge branch above the discharge
branch, with one hysteresis state h in [-1, 1] moving between them with the
charge put through. All cells are equal, so the pack is one cell scaled:
V x Ns, I / Np, Q x Np.

Time is an argument (``step(dt_s)``), so runs are deterministic. Within a step
the current is held constant and the RC voltages and h are updated exactly
(the resistances are taken at the step's starting SOC), so results hardly
depend on the step size. Currents are positive when charging, negative
when discharging (the sensor_msgs/BatteryState convention).

The pack protection acts as a real BMS does, and within the step: the load is
cut off at the cut-off voltage, above the cell's maximum continuous current,
when a constant-power load cannot be delivered (no solution of P = V * I), and
above the protection temperature; the charger is cut off above the maximum
charge current and the protection temperature.
"""
import math

from battery_simulator.core.battery_parameters import BatteryParameters
from battery_simulator.core.battery_states import CutOff, Health, Mode, Snapshot, Status
from battery_simulator.core.cell_tables import OcvCurve, ResistanceTable
from battery_simulator.core.gauge import SAVED_KEYS as GAUGE_SAVED_KEYS
from battery_simulator.core.gauge_models import make_gauge
from battery_simulator.core.parameter_rules import is_number

_KELVIN = 273.15


#: Protection trips that clear by themselves once their cause is gone.
_SELF_CLEARING = (CutOff.OVER_CURRENT, CutOff.POWER_LIMIT, CutOff.OVER_TEMPERATURE)
#: The pack cools this far below the protection temperature before reconnecting, K.
PROTECTION_HYSTERESIS_K = 5.0


#: saved-state keys added with the fast RC pair and the OCV hysteresis (issue 25),
#: with the values a state saved before them resumes with
SINCE_TWO_RC = {'fast_rc_voltage_v': 0.0, 'hysteresis': -1.0}
#: saved-state keys only some packs have: the gauge's (core/gauge.py), the groups' own states
OPTIONAL_SAVED = GAUGE_SAVED_KEYS + ('groups', 'surface_soc_lag')


#: the pack's usable capacity never falls below this fraction of its design capacity (ageing and
#: set_state stop there), so every capacity the model divides by stays positive
MIN_STATE_OF_HEALTH = 0.01
#: the temperatures set_state takes, degC (low, high) inclusive
SET_STATE_TEMPERATURE_C = (-60.0, 150.0)


class BatteryModel:
    """A Li-ion pack: step it with ``step(dt_s)``, read it with ``snapshot()``.

    Lumped (every series group alike: one cell's equations times the pack). A config with a spread,
    groups or balancing is a pack of differing groups, core/pack.py's GroupedPack: build either with
    core/pack.py's ``make_model(params, ...)``. Either way a fuel gauge (core/gauge.py) may stand
    between the truth and what the snapshot's percentage says.
    """

    def __init__(self, params=None, state_of_charge=1.0, mode=Mode.DISCHARGE):
        params = params if params is not None else BatteryParameters()
        if params.has_groups and type(self) is BatteryModel:
            raise TypeError('a config with a spread, groups or balancing is a pack of groups: build it with '
                            'battery_simulator.core.pack.make_model(params, ...)')
        _check_fraction('state_of_charge', state_of_charge)
        self.params = params
        self.ocv = OcvCurve(params.ocv_soc, params.ocv_voltage_v)   # the discharge branch
        # The charge branch less the discharge branch (None: one OCV curve).
        self._ocv_gap = OcvCurve(params.ocv_soc, [c - d for c, d in zip(
            params.ocv_charge_voltage_v, params.ocv_voltage_v)]) if params.ocv_charge_voltage_v else None
        self._hysteresis_per_as = 1.0 / (3600.0 * params.hysteresis_ah)
        self._resistances = ResistanceTable(params)
        self._has_fast_pair = params.r_fast_ohm > 0.0
        self._has_surface_lag = params.surface_soc_lag_s > 0.0
        self._step_decays = (None, None)   # (dt_s, its exponentials): steps mostly repeat their length
        self._scale_at = (None, 1.0)       # (temperature, the Arrhenius factor there)
        self._hysteresis_for = (None, None)  # (current, h after this step at it), from the charger
        self._termination_a = params.pack_termination_current_a
        self.mode = mode
        self.state_of_charge = float(state_of_charge)
        self.rc_voltage_v = 0.0       # voltage across the (slow) RC pair, per cell
        self.fast_rc_voltage_v = 0.0  # voltage across the fast RC pair, per cell
        self.hysteresis = -1.0        # -1 on the discharge branch of the OCV, +1 on the charge branch
        self.surface_soc_lag = 0.0    # bulk less surface SOC (surface_soc_lag_s; > 0 while discharging)
        self.cell_current_a = 0.0     # the current held over the last step
        self.temperature_c = self.initial_temperature_c
        self.discharged_ah = 0.0      # per cell, since start (for the cycle count)
        self.state_of_health = max(MIN_STATE_OF_HEALTH,
                                   1.0 - params.capacity_fade_per_cycle * params.initial_cycle_count)
        self.status = Status.NOT_CHARGING
        self.cut_off = None           # a CutOff while the protection holds the pack disconnected
        self.charger_fault = False    # charger connected but no current flows
        self._extra_loads = {}
        self._extra_current_a = 0.0
        self._extra_power_w = 0.0
        self._capacity_as = 0.0       # usable capacity per cell, A*s
        self.throughput_as = 0.0      # charge through a cell since start, A*s (signed: the gauge counts it)
        self._stuck = None            # (percentage, charge) the gauge_stuck fault holds, or None
        self._update_capacity()
        self.gauge = make_gauge(params.gauge, self.capacity_ah, self.state_of_charge, self)   # true capacity at start
        self._settle_status()
        self.step(0.0)

    # -- inputs ---------------------------------------------------------------

    def set_mode(self, mode):
        """Connect the charger (CHARGE), the load (DISCHARGE) or nothing (IDLE)."""
        if mode is not self.mode:
            self.mode = mode
            self._settle_status()
            self.step(0.0)

    def set_extra_load(self, name, current_a=0.0, power_w=0.0):
        """Add (or replace) a named load term, e.g. motion; zero removes it."""
        if current_a or power_w:
            self._extra_loads[name] = (float(current_a), float(power_w))
        else:
            self._extra_loads.pop(name, None)
        self._extra_current_a = sum(c for c, _ in self._extra_loads.values())
        self._extra_power_w = sum(p for _, p in self._extra_loads.values())

    def set_charger_fault(self, active):
        """A charger that is connected but delivers no current (a failed docking)."""
        self.charger_fault = bool(active)
        self._settle_status()
        self.step(0.0)

    def set_state(self, state_of_charge=None, temperature_c=None, state_of_health=None, gauge_error=None):
        """Put the pack where a test needs it; None leaves a value as it is.

        Raises ValueError (nothing changed) for a value out of range. The RC
        pairs are left settled, as after a long rest (the OCV stays on its branch).
        A state of charge sets the gauge there too; ``gauge_error`` (percentage
        points) is then added to the gauge (a coulomb counter's only).
        """
        if gauge_error is not None:
            if self.gauge is None:
                raise ValueError('gauge_error = %r is invalid: this pack\'s gauge is ideal (it reads the truth); '
                                 'give the config gauge: {model: coulomb_counter}' % (gauge_error,))
            if not is_number(gauge_error):
                raise ValueError('gauge_error = %r is invalid: must be a number of percentage points' % (gauge_error,))
            soc = self.gauge.soc if state_of_charge is None or not is_number(state_of_charge) else state_of_charge
            if not 0.0 <= soc + gauge_error / 100.0 <= 1.0:
                raise ValueError('gauge_error = %r is invalid: it puts the gauge at %.1f %%: the percentage must '
                                 'stay in [0, 100]' % (gauge_error, 100.0 * soc + gauge_error))
        if state_of_charge is not None:
            _check_fraction('state_of_charge', state_of_charge)
        low_c, high_c = SET_STATE_TEMPERATURE_C
        if temperature_c is not None and not (is_number(temperature_c) and low_c <= temperature_c <= high_c):
            raise ValueError('temperature_c = %r is invalid: must be in [%g, %g] degC' % (temperature_c, low_c, high_c))
        if state_of_health is not None:
            _check_fraction('state_of_health', state_of_health)
            if state_of_health < MIN_STATE_OF_HEALTH:
                raise ValueError('state_of_health = %r is invalid: must be in [%g, 1]'
                                 % (state_of_health, MIN_STATE_OF_HEALTH))
        if state_of_charge is not None:
            self.state_of_charge = float(state_of_charge)
            self.rc_voltage_v = 0.0
            self.fast_rc_voltage_v = 0.0
            self.surface_soc_lag = 0.0
        if temperature_c is not None:
            self.temperature_c = float(temperature_c)
        if state_of_health is not None:
            self.state_of_health = float(state_of_health)
            self._update_capacity()
        self.cut_off = None
        if self.gauge is not None:
            if state_of_charge is not None:
                self.gauge.soc = float(state_of_charge)
            if gauge_error is not None:
                self.gauge.add_error(gauge_error)
            self.gauge.restart()
        self._settle_status()
        self.step(0.0)

    def export_state(self):
        """The state that survives a restart, as plain numbers (see restore_state)."""
        state = {'state_of_charge': self.state_of_charge, 'rc_voltage_v': self.rc_voltage_v,
                 'fast_rc_voltage_v': self.fast_rc_voltage_v, 'hysteresis': self.hysteresis,
                 'temperature_c': self.temperature_c, 'discharged_ah': self.discharged_ah,
                 'state_of_health': self.state_of_health}
        if self._has_surface_lag:
            state['surface_soc_lag'] = self.surface_soc_lag
        if self.gauge is not None:
            self.gauge.save(state)
        return state

    def restore_state(self, saved):
        """Resume from ``export_state()`` output; ValueError (nothing changed) if it does not fit.

        A state saved by the single-RC model (no SINCE_TWO_RC keys) resumes with
        the fast pair settled and the OCV on its discharge branch.
        """
        keys = set(BatteryModel.export_state(self)) - set(OPTIONAL_SAVED)
        if not isinstance(saved, dict) or set(saved) - set(OPTIONAL_SAVED) not in (keys, keys - set(SINCE_TWO_RC)):
            raise ValueError('saved state %r is invalid: must have exactly %s (%s may be missing)'
                             % (saved, ', '.join(sorted(keys)), ', '.join(SINCE_TWO_RC)))
        optional = {key: saved[key] for key in OPTIONAL_SAVED if key in saved}
        saved = {key: value for key, value in saved.items() if key not in OPTIONAL_SAVED}
        values = dict(SINCE_TWO_RC, **saved)
        lag = optional.get('surface_soc_lag', 0.0)   # saved only with surface_soc_lag_s (else settled)
        if not all(is_number(v) for v in list(values.values()) + [lag]) or values['discharged_ah'] < 0 \
                or abs(values['rc_voltage_v']) > 1.0 or abs(values['fast_rc_voltage_v']) > 1.0 \
                or abs(values['hysteresis']) > 1.0 or abs(lag) > 1.0:
            raise ValueError('saved state %r is invalid: values out of range' % (saved,))
        self.set_state(values['state_of_charge'], values['temperature_c'], values['state_of_health'])
        self.rc_voltage_v = float(values['rc_voltage_v'])
        self.fast_rc_voltage_v = float(values['fast_rc_voltage_v'])
        self.hysteresis = float(values['hysteresis'])
        self.discharged_ah = float(values['discharged_ah'])
        self.surface_soc_lag = float(lag) if self._has_surface_lag else 0.0
        if self.gauge is not None:
            self.gauge.restore(optional)   # what it kept; the rest as it starts (at the truth)
        self._restore_groups(optional.get('groups'))
        self._settle_status()
        self.step(0.0)

    def _restore_groups(self, saved_groups):
        """A pack of groups takes its groups' saved states (a lumped pack has none)."""
        return

    # -- the update -----------------------------------------------------------

    def step(self, dt_s, current_a=None, power_w=None):
        """Advance by ``dt_s`` seconds (see _step_truth); the gauge counts what its sensor saw."""
        gauge = self.gauge
        if gauge is None:
            self._step_truth(dt_s, current_a, power_w)
            return
        throughput, status = self.throughput_as, self.status
        self._step_truth(dt_s, current_a, power_w)
        gauge.after_step(self, (self.throughput_as - throughput) * self.params.cells_parallel, dt_s, status)

    def _step_truth(self, dt_s, current_a=None, power_w=None):
        """Advance the pack itself by ``dt_s`` seconds.

        Without arguments the mode decides the current. ``current_a`` (A) or
        ``power_w`` (W) per pack replaces it for this step: positive charges
        (the charger limits it by CV), negative discharges (until cut-off).
        A step of 0 s settles the current and status without moving time.
        """
        if not dt_s >= 0.0:
            return
        if current_a is None and power_w is None:
            demand = self._mode_demand_a()
        elif current_a is not None:
            demand = current_a
        elif power_w >= 0.0:
            demand = power_w / self.voltage_v
        else:
            demand = self._load_current_a(0.0, -power_w)
        self._clear_protection(demand)
        start = self._state()
        self._advance(dt_s, demand)
        if self.status is Status.DISCHARGING and self._trip() is not None:
            self._cut_off_within(dt_s, demand, start)
        elif self.status is Status.CHARGING and self._too_hot():
            self._advance_until(dt_s, demand, start, self._too_hot)
            self._disconnect(CutOff.OVER_TEMPERATURE, Status.NOT_CHARGING)

    def _state(self):
        return (self.state_of_charge, self.rc_voltage_v, self.fast_rc_voltage_v, self.hysteresis,
                self.temperature_c, self.discharged_ah, self.state_of_health, self.status, self._capacity_as,
                self.throughput_as, self.surface_soc_lag)

    def _restore(self, state):
        (self.state_of_charge, self.rc_voltage_v, self.fast_rc_voltage_v, self.hysteresis,
         self.temperature_c, self.discharged_ah, self.state_of_health, self.status, self._capacity_as,
         self.throughput_as, self.surface_soc_lag) = state

    def _trip(self):
        """The CutOff the pack protection would act on now, or None."""
        if self.state_of_charge <= 0.0 \
                or self.voltage_v <= self.params.cell_cutoff_voltage_v * self.params.cells_series:
            return CutOff.UNDER_VOLTAGE
        if self._too_hot():
            return CutOff.OVER_TEMPERATURE
        return None

    def _too_hot(self):
        return self.temperature_c >= self.params.protection_temperature_c

    def _cut_off_within(self, dt_s, demand, start):
        """Redo the step up to the moment the protection acts, then disconnect the load."""
        self._advance_until(dt_s, demand, start, lambda: self._trip() is not None)
        self._disconnect(self._trip() or CutOff.UNDER_VOLTAGE, Status.EMPTY)

    def _advance_until(self, dt_s, demand, start, tripped):
        """Bisect for the first moment within the step at which ``tripped()`` holds; end there."""
        low, high = 0.0, dt_s
        for _ in range(30):
            middle = 0.5 * (low + high)
            self._restore(start)
            self._advance(middle, demand)
            if tripped():
                high = middle
            else:
                low = middle
        self._restore(start)
        self._advance(high, demand)

    def _advance(self, dt_s, demand, limit_a=None):
        """The exact update for ``demand`` A per pack held over ``dt_s``; a charge current of at most
        ``limit_a`` per cell if given (a group in a string: the string's current)."""
        p = self.params
        cell_demand = demand / p.cells_parallel
        resistance_scale = self._resistance_scale()
        step_dt_s, decays = self._step_decays
        if dt_s != step_dt_s:
            decay = math.exp(-dt_s / p.tau1_s)
            fast_decay = math.exp(-dt_s / p.tau_fast_s) if self._has_fast_pair else 1.0
            # Where in the step each resistance is taken when it changes with SOC: R0 at
            # the end (the terminal voltage there), an RC pair at the moment whose value
            # its exponential memory of a linear change equals.
            fractions = (1.0, _memory_fraction(dt_s, p.tau1_s, decay),
                         _memory_fraction(dt_s, p.tau_fast_s, fast_decay) if self._has_fast_pair else 0.5)
            decays = (decay, fast_decay,
                      math.exp(-dt_s * p.cell_heat_transfer_w_per_k / p.cell_heat_capacity_j_per_k), fractions,
                      math.exp(-dt_s / p.tau_surface_s) if self._has_surface_lag else 1.0)
            self._step_decays = (dt_s, decays)
        decay, fast_decay, thermal_decay, fractions, surface_decay = decays
        by_soc = self._resistances.soc_points is not None
        if not by_soc:
            r0, r1, r_fast = self._resistances.at(self.state_of_charge, cell_demand > 0.0)
        else:
            # the SOC change of the demanded current (the charger may give less)
            soc_change = (cell_demand * dt_s / self._capacity_as) if -math.inf < cell_demand < math.inf else 0.0
            r0, r1, r_fast = self._resistances.along(self.state_of_charge, soc_change, fractions,
                                                     cell_demand > 0.0)
            # the heat's mean over the step: each at the middle
            heat_resistances = self._resistances.along(self.state_of_charge, soc_change, (0.5, 0.5, 0.5),
                                                       cell_demand > 0.0)
        r0 = r0 * resistance_scale
        r1 = r1 * resistance_scale
        rc_gain = r1 * (1.0 - decay)
        if self._has_fast_pair:
            r_fast = r_fast * resistance_scale
            fast_gain = r_fast * (1.0 - fast_decay)
        else:
            fast_gain = 0.0

        if cell_demand > 0.0:
            current = self._charge_current(cell_demand, dt_s, decay, rc_gain, fast_decay, fast_gain, r0,
                                           surface_decay)
            if limit_a is not None and current > limit_a:
                current = limit_a
        elif cell_demand < 0.0:
            current = self._discharge_current(cell_demand)
        else:
            current = 0.0
            if self.status not in (Status.FULL, Status.EMPTY):
                self.status = Status.NOT_CHARGING

        efficiency = p.coulombic_efficiency if current > 0.0 else 1.0
        soc = self.state_of_charge + efficiency * current * dt_s / self._capacity_as
        v1_start = self.rc_voltage_v
        self.rc_voltage_v = decay * v1_start + rc_gain * current
        fast_start = self.fast_rc_voltage_v
        self.fast_rc_voltage_v = fast_decay * fast_start + fast_gain * current
        if self._has_surface_lag:
            # the lag settles at lag_s seconds of the current's SOC change (exact for the step's current)
            settled = -p.surface_soc_lag_s * current / self._capacity_as
            self.surface_soc_lag = settled + (self.surface_soc_lag - settled) * surface_decay
        if self._ocv_gap is not None and current != 0.0 and self.hysteresis != (1.0 if current > 0.0 else -1.0):
            for_current, hysteresis = self._hysteresis_for
            self.hysteresis = hysteresis if for_current == current else self._hysteresis_after(current, dt_s)
        self.cell_current_a = current
        self.throughput_as += current * dt_s
        if current < 0.0:
            discharged_ah = -current * dt_s / 3600.0
            self.discharged_ah += discharged_ah
            self.state_of_health = max(MIN_STATE_OF_HEALTH, self.state_of_health
                                       - p.capacity_fade_per_cycle * discharged_ah / p.cell_capacity_ah)
            self._update_capacity()
        if current > 0.0 and soc > 1.0 - 1e-12:
            soc = 1.0   # the step that fills the cell (its current was cut to fill it exactly), to rounding
        self.state_of_charge = 0.0 if soc < 0.0 else (1.0 if soc > 1.0 else soc)

        # Lumped thermal mass, exact for the heat held over the step; the RC
        # voltage's exact mean over the step gives its share of the heat.
        if by_soc:
            r0 = heat_resistances[0] * resistance_scale
            r1 = heat_resistances[1] * resistance_scale
            r_fast = heat_resistances[2] * resistance_scale
        v1_settled = r1 * current
        fraction = (1.0 - decay) * p.tau1_s / dt_s if dt_s > 0.0 else 1.0
        v1_mean = v1_settled + (v1_start - v1_settled) * fraction
        heat_w = current * current * r0 + current * v1_mean
        if self._has_fast_pair:
            fast_settled = r_fast * current
            fraction = (1.0 - fast_decay) * p.tau_fast_s / dt_s if dt_s > 0.0 else 1.0
            heat_w += current * (fast_settled + (fast_start - fast_settled) * fraction)
        conductance = p.cell_heat_transfer_w_per_k
        settled_c = p.ambient_temperature_c + heat_w / conductance
        self.temperature_c = settled_c + (self.temperature_c - settled_c) * thermal_decay

        if self.status is Status.CHARGING and self.state_of_charge >= 1.0 and limit_a is None:
            self._become_full()   # (a group in a string: the pack decides)

    def _mode_demand_a(self):
        if self.mode is Mode.CHARGE:
            return self.params.charge_current_a
        if self.mode is Mode.DISCHARGE:
            return self._load_current_a(self.params.load_current_a + self._extra_current_a,
                                        self.params.load_power_w + self._extra_power_w)
        return 0.0

    def _load_current_a(self, current_a, power_w):
        """The pack current (negative) that feeds ``current_a`` plus ``power_w`` at the terminals.

        Solves (I - I_c) * (E - R0 * I) = P per cell, E being the OCV plus the
        RC voltage: the lower root is the stable operating point. With no real
        root the pack cannot deliver the power: -inf, which the protection cuts off.
        """
        p = self.params
        cell_current = current_a / p.cells_parallel
        cell_power = power_w / (p.cells_series * p.cells_parallel)
        if cell_power <= 0.0:
            return -current_a
        emf = self.open_circuit_voltage_v + self.rc_voltage_v + self.fast_rc_voltage_v
        r0 = self._resistances.r0_at(self.state_of_charge, False) * self._resistance_scale()
        discriminant = (emf - r0 * cell_current) ** 2 - 4.0 * r0 * cell_power
        if discriminant < 0.0 or emf <= 0.0:
            return -math.inf
        cell_load = (emf + r0 * cell_current - math.sqrt(discriminant)) / (2.0 * r0)
        return -cell_load * p.cells_parallel

    def _charge_current(self, cell_demand, dt_s, decay, rc_gain, fast_decay, fast_gain, r0, surface_decay=1.0):
        """CC up to the charge voltage, then CV with the current tapering."""
        if self.status is Status.FULL or self.charger_fault or self.cut_off is not None:
            self.status = self.status if self.status is Status.FULL else Status.NOT_CHARGING
            return 0.0
        p = self.params
        if cell_demand > p.cell_max_charge_current_a:
            self._disconnect(CutOff.OVER_CURRENT, Status.NOT_CHARGING)
            return 0.0
        soc = self.state_of_charge
        soc_gain = p.coulombic_efficiency * dt_s / self._capacity_as
        # The surface SOC the OCV is read at (the bulk one without surface_soc_lag_s): at the step's end
        # surface_at + surface_gain * current
        surface_at, surface_gain = soc, soc_gain
        if self._has_surface_lag:
            surface_at = soc - self.surface_soc_lag * surface_decay
            surface_gain = soc_gain + p.surface_soc_lag_s * (1.0 - surface_decay) / self._capacity_as
        # The current that ends the step exactly at the charge voltage
        # (implicit in SOC, so large steps stay stable).
        headroom = (p.cell_charge_voltage_v - self.ocv.voltage(surface_at) - decay * self.rc_voltage_v
                    - fast_decay * self.fast_rc_voltage_v)
        resistance = r0 + rc_gain + fast_gain
        if self._ocv_gap is None:
            cv_current = headroom / (resistance + self.ocv.slope(surface_at) * surface_gain)
        else:
            # The OCV also rises by h's move towards the charge branch: take h at
            # the end of the step for the CC current, then (if CV) for the CV current.
            slope, gap, gap_slope = self._ocv_gap.slopes_beside(self.ocv, surface_at)
            current = cell_demand
            for _ in range(2 if self.hysteresis != 1.0 else 1):
                hysteresis = self._hysteresis_after(current, dt_s) if current > 0.0 else self.hysteresis
                self._hysteresis_for = (current, hysteresis)   # _advance's h if this current flows
                weight = 0.5 * (1.0 + hysteresis)
                cv_current = (headroom - weight * gap) / (resistance + (slope + weight * gap_slope) * surface_gain)
                if cv_current >= cell_demand:
                    break
                current = cv_current
        current = min(cell_demand, cv_current)
        if current < cell_demand and current * p.cells_parallel <= self._termination_a:
            self._become_full()
            return 0.0
        self.status = Status.CHARGING
        room = (1.0 - soc) / soc_gain if dt_s > 0.0 else math.inf
        # No more than fills the cell: a step that reaches SOC 1 ends there exactly (charge is conserved)
        # and the charge ends with it. The OCV table's top is fitted so that this and the taper's end
        # coincide (docs/model.md): SOC 1 is the state the charge reaches at its termination current.
        return current if current < room else room

    def _discharge_current(self, cell_demand):
        if self.status is Status.EMPTY:
            return 0.0
        if math.isinf(cell_demand):
            self._disconnect(CutOff.POWER_LIMIT, Status.EMPTY)
            return 0.0
        if -cell_demand > self.params.cell_max_discharge_current_a:
            self._disconnect(CutOff.OVER_CURRENT, Status.EMPTY)
            return 0.0
        self.status = Status.DISCHARGING
        return cell_demand

    def _clear_protection(self, demand):
        """A BMS reconnects once an over-current or power demand is gone, or the pack has cooled; a charger
        connected after an under-voltage cut-off charges (as connecting it in CHARGE mode does)."""
        if self.cut_off is CutOff.UNDER_VOLTAGE and demand > 0.0:
            self.cut_off = None
            self.status = Status.NOT_CHARGING   # the charge step makes it CHARGING
            return
        if self.cut_off not in _SELF_CLEARING:
            return
        cell_demand = demand / self.params.cells_parallel
        if self.cut_off is CutOff.OVER_TEMPERATURE:
            cleared = self.temperature_c < self.params.protection_temperature_c - PROTECTION_HYSTERESIS_K
        elif cell_demand < 0.0:
            cleared = -cell_demand <= self.params.cell_max_discharge_current_a
        else:
            cleared = cell_demand <= self.params.cell_max_charge_current_a
        if cleared:
            self.cut_off = None
            self._settle_status()

    def _disconnect(self, cut_off, status):
        self.cut_off = cut_off
        self.status = status
        self.cell_current_a = 0.0

    def _become_full(self):
        # The charge has ended: at the termination current, or as the cell is filled (SOC 1). The state of
        # charge stays where the charge put it (no step: charge is conserved); the OCV table is fitted so
        # that the two ends coincide (tools/fit_lg_hg2.py, docs/model.md).
        self.status = Status.FULL
        self.cell_current_a = 0.0

    def _settle_status(self):
        """The status right after a mode change (FULL/EMPTY persist only in their mode)."""
        self.cell_current_a = 0.0
        if self.cut_off is CutOff.UNDER_VOLTAGE or self.cut_off is None:
            self.cut_off = None
            if self.mode is Mode.DISCHARGE and self._trip() is not None:
                self.cut_off = self._trip()
        if self.mode is Mode.CHARGE:
            if self.charger_fault or self.cut_off is not None:
                self.status = Status.NOT_CHARGING
            else:
                self.status = Status.FULL if self.state_of_charge >= 1.0 else Status.CHARGING
        elif self.mode is Mode.DISCHARGE:
            self.status = Status.EMPTY if self.cut_off is not None else Status.DISCHARGING
        else:
            self.status = Status.NOT_CHARGING

    def _resistance_scale(self):
        temperature_c, scale = self._scale_at
        if self.temperature_c == temperature_c:
            return scale
        p = self.params
        if not p.arrhenius_temperature_k:
            return 1.0
        scale = math.exp(p.arrhenius_temperature_k * (
            1.0 / (self.temperature_c + _KELVIN) - 1.0 / (p.reference_temperature_c + _KELVIN)))
        self._scale_at = (self.temperature_c, scale)
        return scale

    def _hysteresis_after(self, current, dt_s):
        """h after ``current`` (A per cell, not 0) held for ``dt_s``: exact in the charge put through."""
        target = 1.0 if current > 0.0 else -1.0
        after = target + (self.hysteresis - target) * math.exp(-abs(current) * dt_s * self._hysteresis_per_as)
        return target if -1e-12 < after - target < 1e-12 else after   # settled: later steps skip the update

    def _update_capacity(self):
        self._capacity_as = self.params.cell_capacity_ah * 3600.0 * self.state_of_health

    # -- outputs --------------------------------------------------------------

    @property
    def initial_temperature_c(self):
        """The temperature at start (and after a reset), degC."""
        p = self.params
        return p.ambient_temperature_c if p.initial_temperature_c is None else p.initial_temperature_c

    @property
    def cycle_count(self):
        """Equivalent full cycles done, including the initial count."""
        return self.params.initial_cycle_count + self.discharged_ah / self.params.cell_capacity_ah

    @property
    def open_circuit_voltage_v(self):
        """OCV of one cell now, V: on the discharge branch, the charge branch or between (hysteresis)."""
        soc = self.surface_soc
        if self._ocv_gap is None:
            return self.ocv.voltage(soc)
        return self._ocv_gap.voltage_beside(self.ocv, soc, 0.5 * (1.0 + self.hysteresis))

    @property
    def surface_soc(self):
        """The state of charge the OCV is read at: the bulk one less the surface lag (surface_soc_lag_s)."""
        return self.state_of_charge - self.surface_soc_lag if self._has_surface_lag else self.state_of_charge

    @property
    def cell_voltage_v(self):
        """Terminal voltage of one cell under the present current, V."""
        current = self.cell_current_a
        r0 = self._resistances.r0_at(self.state_of_charge, current > 0.0)
        return (self.open_circuit_voltage_v + self.rc_voltage_v + self.fast_rc_voltage_v
                + current * r0 * self._resistance_scale())

    @property
    def voltage_v(self):
        """Pack terminal voltage, V."""
        return self.cell_voltage_v * self.params.cells_series

    @property
    def current_a(self):
        """Pack current, A: positive charging, negative discharging; a full pack held full on the dock
        shows the current the charger tops it up with (held_full_current_a)."""
        if self.status is Status.FULL and self.mode is Mode.CHARGE and self.params.charger_holds_full:
            return self.held_full_current_a
        return self.cell_current_a * self.params.cells_parallel

    def extra_loads(self):
        """The named loads (set_extra_load): {name: (current A, power W)}."""
        return dict(self._extra_loads)

    @property
    def held_full_current_a(self):
        """What the charger delivers to hold a full pack full on the dock (charger_holds_full), A: the
        robot's own load (base load, payloads, motion) at the pack's voltage, replaced as it is drawn, so
        the cells' charge stays where it is (charge is conserved: the load takes what the charger gives)."""
        p = self.params
        power_w = p.load_power_w + self._extra_power_w
        voltage_v = self.voltage_v
        return p.load_current_a + self._extra_current_a + (power_w / voltage_v if voltage_v > 0.0 else 0.0)

    @property
    def extra_power_w(self):
        """The named power loads (set_extra_load) together, W: they apply while discharging."""
        return self._extra_power_w

    @property
    def capacity_ah(self):
        """Pack capacity now (design capacity x state of health), Ah."""
        return self._capacity_as / 3600.0 * self.params.cells_parallel

    @property
    def time_remaining_s(self):
        """At the present current: seconds to empty (discharging) or full (charging) as the gauge reads the
        charge (what a robot reads: the truth with an ideal gauge); None otherwise."""
        current = self.current_a
        if self.status is Status.DISCHARGING and current < 0.0:
            return self.gauge_reading()[1] * 3600.0 / -current
        if self.status is Status.CHARGING and current > 0.0:
            _, charge, capacity = self.gauge_reading()
            return max(0.0, capacity - charge) * 3600.0 / current
        return None

    @property
    def health(self):
        """GOOD, or OVERHEAT / COLD past the configured temperature limits."""
        if self.temperature_c > self.params.overheat_temperature_c:
            return Health.OVERHEAT
        if self.temperature_c < self.params.cold_temperature_c:
            return Health.COLD
        return Health.GOOD

    def gauge_reading(self):
        """(percentage, charge Ah, capacity Ah) as the gauge reads them (the truth with an ideal gauge)."""
        if self._stuck is not None:
            return self._stuck
        if self.gauge is None:
            capacity = self.capacity_ah
            return 100.0 * self.state_of_charge, self.state_of_charge * capacity, capacity
        return self.gauge.reading()

    def cell_readings(self):
        """(voltages, temperatures) of the series groups: all alike in a lumped pack."""
        series = self.params.cells_series
        return (self.cell_voltage_v,) * series, (self.temperature_c,) * series

    def set_gauge_stuck(self, active):
        """The gauge_stuck fault: the reported percentage and charge freeze (the truth moves on)."""
        self._stuck = self.gauge_reading() if active else None

    def snapshot(self):
        """All outputs at this instant, in pack units."""
        cell_v = self.cell_voltage_v
        percentage, charge, capacity = self.gauge_reading()
        cell_voltages, cell_temperatures = self.cell_readings()
        return Snapshot(
            percentage=percentage,
            voltage_v=cell_v * self.params.cells_series,
            current_a=self.current_a,
            temperature_c=self.temperature_c,
            charge_ah=charge,
            capacity_ah=capacity,
            design_capacity_ah=self.params.design_capacity_ah,
            cell_voltage_v=cell_v,
            mode=self.mode,
            status=self.status,
            health=self.health,
            cycle_count=self.cycle_count,
            state_of_health=self.state_of_health,
            cut_off=self.cut_off,
            time_remaining_s=self.time_remaining_s,
            charger_fault=self.charger_fault,
            true_percentage=100.0 * self.state_of_charge,
            cell_voltages_v=cell_voltages,
            cell_temperatures_c=cell_temperatures,
        )


def _memory_fraction(dt_s, tau_s, decay):
    """The fraction of a step at which a linearly changing resistance, seen through an RC pair's
    exponential memory, has the value that gives the pair's exact end voltage."""
    ratio = dt_s / tau_s
    if ratio < 1e-4:
        return 0.5 + ratio / 12.0
    return 1.0 / (1.0 - decay) - 1.0 / ratio


def _check_fraction(name, value):
    if not (is_number(value) and 0.0 <= value <= 1.0):
        raise ValueError('%s = %r is invalid: must be in [0, 1]' % (name, value))
