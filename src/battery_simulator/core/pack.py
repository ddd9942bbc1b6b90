"""A pack of series groups that differ (no ROS): the weakest ends the discharge, the highest the charge.

Cells of one batch differ (capacity by 0.2-1 %, resistance by 0.5-4 %). In a
series string every group carries the same current, so:

- the discharge cuts off when the LOWEST group reaches the cell cut-off
  voltage (the BMS watches every group), while the others still hold charge;
- the charge's constant-voltage phase holds the HIGHEST group at the cell
  charge voltage, so the pack stops charging while the others are short of
  full: an imbalanced pack charges to less than full;
- passive balancing bleeds ``balancing.current_a`` from every group more than
  ``threshold_v`` above the lowest while charging above ``start_voltage_v``,
  its heat into that group, and so pulls the groups together, slowly.

Each group is a one-group BatteryModel (its cells in parallel) with its own
charge, RC states, hysteresis and temperature; this class drives them with the
one current, and keeps the pack-level attributes the rest of the package
reads. The pack's state of charge is the charge it can still give over what it
can give plus what it can still take,

    SOC = Q_out / (Q_out + Q_in),  Q_out = min_i soc_i C_i,  Q_in = min_i (1 - soc_i) C_i

(1 when the highest group is full, 0 when the lowest is empty, the plain SOC
when the groups are alike).

The charge ends as the lumped model's does: when the string's current tapers to
the termination current, or as it fills a group (that group's SOC reaches 1: no
group takes more than fills it). No group's charge moves but by the current it
carried (no step to 100 %), so charge is conserved, the groups keep their
differences, and a pack of alike groups cycles exactly as the lumped one.

``make_model(params, ...)`` builds the model of a config: this pack when the
config has a spread, groups or balancing, else the lumped BatteryModel.
"""
import math
import random
from dataclasses import replace

from battery_simulator.core.battery_model import BatteryModel
from battery_simulator.core.battery_states import CutOff, Mode, Status
from battery_simulator.core.parameter_rules import SPREAD_SIGMAS


#: a group this far below its charge voltage is in its CC phase: the string's charge is not tried per group
CV_MARGIN_V = 0.15


def make_model(params=None, state_of_charge=1.0, mode=Mode.DISCHARGE):
    """The model of ``params``: a GroupedPack when the config has a spread, groups or balancing (Part 5),
    else the lumped BatteryModel (None: the default parameters)."""
    if params is not None and params.has_groups:
        return GroupedPack(params, state_of_charge, mode)
    return BatteryModel(params, state_of_charge, mode)


def group_factors(params):
    """[(capacity factor, resistance factor, initial SOC offset)] of the series groups: the config's
    ``groups``, or drawn from the spreads with ``spread_seed`` (a normal law, clipped to +-3 sigma:
    parameter_rules.py keeps the spreads below 1/3, so every factor is > 0)."""
    if params.groups:
        return [(float(g.get('capacity_factor', 1.0)), float(g.get('resistance_factor', 1.0)),
                 float(g.get('initial_soc_offset', 0.0))) for g in params.groups]
    draw = random.Random(params.spread_seed)

    def factor(spread):
        return 1.0 + spread * max(-SPREAD_SIGMAS, min(SPREAD_SIGMAS, draw.gauss(0.0, 1.0)))
    return [(factor(params.capacity_spread), factor(params.resistance_spread), 0.0)
            for _ in range(params.cells_series)]


def group_params(params, capacity_factor, resistance_factor):
    """One series group as a pack of its own: the pack's cells in parallel, its capacity and resistances
    scaled; loads and charger come from the pack (they are given to it as currents)."""
    return replace(params, name=params.name + ' group', cells_series=1,
                   cell_capacity_ah=params.cell_capacity_ah * capacity_factor,
                   r0_ohm=params.r0_ohm * resistance_factor, r1_ohm=params.r1_ohm * resistance_factor,
                   r_fast_ohm=params.r_fast_ohm * resistance_factor, load_power_w=0.0, drive_power_w_per_mps=0.0,
                   turn_power_w_per_radps=0.0, capacity_spread=0.0, resistance_spread=0.0, groups=(),
                   balancing=None, gauge=None, termination_current_a=params.pack_termination_current_a)


class GroupedPack(BatteryModel):
    """A pack of ``cells_series`` differing groups (make_model returns one for such a config)."""

    def __init__(self, params, state_of_charge=1.0, mode=Mode.DISCHARGE):
        self.groups = [BatteryModel(group_params(params, capacity, resistance),
                                    state_of_charge=min(1.0, max(0.0, state_of_charge + offset)), mode=mode)
                       for capacity, resistance, offset in group_factors(params)]
        self.bleeding = [False] * len(self.groups)   # which groups balancing bleeds now
        self._voltages = [0.0] * len(self.groups)    # the groups' voltages as the charge step began
        super().__init__(params, state_of_charge, mode)
        self._sync()

    # -- what the rest of the package reads ---------------------------------------------

    def _sync(self):
        """The pack-level attributes from the groups (one pass: it runs at every step)."""
        charge_out = charge_in = math.inf
        discharged = 0.0
        health = 1.0
        for group in self.groups:
            capacity, soc = group._capacity_as, group.state_of_charge
            if soc * capacity < charge_out:
                charge_out = soc * capacity
            if (1.0 - soc) * capacity < charge_in:
                charge_in = (1.0 - soc) * capacity
            discharged += group.discharged_ah
            if group.state_of_health < health:
                health = group.state_of_health
        total = charge_out + charge_in   # a group's capacity share: never 0 (MIN_STATE_OF_HEALTH)
        self.state_of_charge = charge_out / total
        self._capacity_as = total
        self.discharged_ah = discharged / len(self.groups)
        self.state_of_health = health
        self.cell_current_a = self.groups[0].cell_current_a

    @property
    def temperature_c(self):
        """The hottest group's (health and protection watch it)."""
        return max(g.temperature_c for g in self.groups)

    @temperature_c.setter
    def temperature_c(self, value):   # set_state, the overheat fault: every group
        for group in getattr(self, 'groups', ()):
            group.temperature_c = value

    @property
    def cell_voltage_v(self):
        """The mean group's terminal voltage, V (the pack's is the sum)."""
        return sum(g.cell_voltage_v for g in self.groups) / len(self.groups)

    @property
    def open_circuit_voltage_v(self):
        return sum(g.open_circuit_voltage_v for g in self.groups) / len(self.groups)

    def cell_readings(self):
        return tuple(g.cell_voltage_v for g in self.groups), tuple(g.temperature_c for g in self.groups)

    def _update_capacity(self):
        if hasattr(self, 'groups'):
            for group in self.groups:
                group._update_capacity()
            self._sync()
        else:
            super()._update_capacity()

    # -- the update ------------------------------------------------------------------------

    def _state(self):
        return (tuple(g._state() for g in self.groups), self.status, self.throughput_as, tuple(self.bleeding))

    def _restore(self, state):
        groups, self.status, self.throughput_as, bleeding = state
        for group, saved in zip(self.groups, groups):
            group._restore(saved)
        self.bleeding = list(bleeding)
        self._sync()

    def _trip(self):
        """Under-voltage when the lowest group reaches the cell cut-off; over-temperature at the hottest."""
        p = self.params
        if any(g.state_of_charge <= 0.0 or g.cell_voltage_v <= p.cell_cutoff_voltage_v for g in self.groups):
            return CutOff.UNDER_VOLTAGE
        if self._too_hot():
            return CutOff.OVER_TEMPERATURE
        return None

    def _load_current_a(self, current_a, power_w):
        """The string's current that feeds ``current_a`` plus ``power_w`` (the lumped rule over the sum
        of the groups' EMFs and resistances)."""
        p = self.params
        cell_current = current_a / p.cells_parallel
        string_power = power_w / p.cells_parallel
        if string_power <= 0.0:
            return -current_a
        emf = sum(g.open_circuit_voltage_v + g.rc_voltage_v + g.fast_rc_voltage_v for g in self.groups)
        r0 = sum(g._resistances.r0_at(g.state_of_charge, False) * g._resistance_scale() for g in self.groups)
        discriminant = (emf - r0 * cell_current) ** 2 - 4.0 * r0 * string_power
        if discriminant < 0.0 or emf <= 0.0:
            return -math.inf
        return -(emf + r0 * cell_current - math.sqrt(discriminant)) / (2.0 * r0) * p.cells_parallel

    def _advance(self, dt_s, demand):
        """Every group over ``dt_s`` with the string's one current (less a bleed where balancing acts)."""
        p = self.params
        groups = self.groups
        cell_demand = demand / p.cells_parallel
        if cell_demand > 0.0:
            current = self._charge_groups(dt_s, demand)   # the groups charged, if it is > 0
        elif cell_demand < 0.0:
            current = self._discharge_current(cell_demand) * p.cells_parallel
        else:
            current = 0.0
            if self.status not in (Status.FULL, Status.EMPTY):
                self.status = Status.NOT_CHARGING
        if not current > 0.0:
            # the groups follow the string (their own cut-off and charger fault never act: the pack's do)
            for group in groups:
                group.status = Status.DISCHARGING
                group._advance(dt_s, current)
            if any(self.bleeding):
                self.bleeding = [False] * len(groups)
        self.throughput_as += current / p.cells_parallel * dt_s
        self._sync()
        self.cell_current_a = current / p.cells_parallel
        if current > 0.0:
            self.status = Status.CHARGING
            if any(g.state_of_charge >= 1.0 for g in groups) or self._terminates(current, demand):
                self._end_charge()   # the step filled a group, or the charger saw its termination current

    def _charge_groups(self, dt_s, demand):
        """Charge every group over ``dt_s`` at the current the most limiting group's CC-CV allows (the
        least of theirs: the highest group is held at its charge voltage), less a bleed where balancing
        acts; return it. 0 (nothing stepped) when no charge flows, and FULL at the taper's end.

        Each group's current is computed once, in its own step: far from the charge voltage (CC) every
        group takes the demand; near it the highest group is tried (its step kept) and the others step
        at its current, capped by their own CC-CV. Only when one of them allows less (it limits, not
        the highest) are they all tried and stepped again. A group steps with the string's demand as
        the lumped model does (its resistances along that current), its current capped at the string's:
        alike groups take the lumped model's very step."""
        if self.status is Status.FULL or self.charger_fault or self.cut_off is not None:
            self.status = self.status if self.status is Status.FULL else Status.NOT_CHARGING
            return 0.0
        p = self.params
        if demand / p.cells_parallel > p.cell_max_charge_current_a:
            self._disconnect(CutOff.OVER_CURRENT, Status.NOT_CHARGING)
            return 0.0
        groups = self.groups
        self._voltages = voltages = [g.cell_voltage_v for g in groups]   # _bleeds reads them too
        highest = max(voltages)
        if highest < p.cell_charge_voltage_v - CV_MARGIN_V:
            return demand if self._charge_at(dt_s, demand, demand, {}) else self._charge_tried(dt_s, demand)
        first = voltages.index(highest)
        tried = {first: self._try(first, dt_s, demand)}
        current, _, tapered = tried[first]
        if tapered:
            self._end_charge()
            return 0.0
        if current > 0.0 and self._charge_at(dt_s, demand, current, tried):
            return current
        return self._charge_tried(dt_s, demand)

    def _try(self, index, dt_s, demand):
        """(the pack current group ``index``'s CC-CV allows over ``dt_s`` at ``demand``, its state after
        that step, whether its taper has ended there: at the termination current); the group is left as
        it was. A group that the step fills (SOC 1) allows what fills it."""
        group = self.groups[index]
        saved = group._state()
        group.status = Status.CHARGING
        group._advance(dt_s, demand, math.inf)   # (a group filled in this step stays CHARGING: the pack decides)
        charging = group.status is Status.CHARGING
        tried = (group.cell_current_a * self.params.cells_parallel if charging else 0.0, group._state(),
                 group.status is Status.FULL)
        group._restore(saved)
        return tried

    def _charge_tried(self, dt_s, demand):
        """Every group tried at ``demand``: the least current wins (0 and FULL at the taper's end)."""
        tried = {index: self._try(index, dt_s, demand) for index in range(len(self.groups))}
        current = min(tried[index][0] for index in range(len(self.groups)))
        if current <= 0.0 or any(ended for _, _, ended in tried.values()):
            self._end_charge()   # a group's taper has ended (or a group is full): the string takes no more
            return 0.0
        self._charge_at(dt_s, demand, current, tried, check=False)
        return current

    def _charge_at(self, dt_s, demand, current, tried, check=True):
        """Step every group at the string's ``current`` (less its bleed): a tried group at that very
        current keeps its tried step. With ``check``, False (every group as it was) as soon as a group's
        own CC-CV allows less: it, not the string, limits."""
        p = self.params
        groups = self.groups
        bleeds = self._bleeds(current) if p.balancing else None
        starts = [g._state() for g in groups] if check else None
        for index, group in enumerate(groups):
            bleed = bleeds[index] if bleeds else 0.0
            limit = (current - bleed) / p.cells_parallel
            done = tried.get(index)
            if done is not None and done[0] == current and not bleed:
                group._restore(done[1])
                group.cell_current_a = limit
                continue
            group.status = Status.CHARGING
            group._advance(dt_s, demand, limit)
            if check and (group.status is not Status.CHARGING or group.cell_current_a < limit * (1.0 - 1e-12)):
                for each, start in zip(groups, starts):
                    each._restore(start)
                return False
            if bleed:   # the bleed resistor's heat, into the group's cells (held over the step)
                self._heat(group, bleed * group.cell_voltage_v / p.cells_parallel, dt_s)
        if bleeds:   # (without balancing no group ever bleeds)
            self.bleeding = [bool(b) for b in bleeds]
        return True

    def _terminates(self, current, demand):
        """The charger's own rule on the string's ``current`` (what it measures, A) in a step just taken: in its
        CV phase (less than ``demand``) at or below the termination current it ends the charge. A group's own
        taper ends before such a step (``_try``); this is for a string held at that current otherwise: a group
        about to fill allows only what fills it, and balancing bled that much past it, so it never filled
        (lg_hg2_7s4p_aged: the string at 0.05 A, the bleed, for 11500 s after a 0.2 A termination was due; its
        gauge, rightly, saw its end of charge there, 3.2 h before the model's FULL)."""
        return current < demand and current <= self._termination_a

    def _end_charge(self):
        """The charge has ended (the taper at the termination current, or a group filled): FULL, no current in
        any group; every group's charge stays where the string's current put it."""
        for group in self.groups:
            group._become_full()
        self._become_full()

    def _bleeds(self, current):
        """The bleed current of each group in a charging step at the string's ``current`` (> 0), A."""
        balancing = self.params.balancing
        voltages = self._voltages   # as the step began (_charge_groups)
        if max(voltages) < balancing['start_voltage_v']:
            return [0.0] * len(self.groups)
        lowest = min(voltages)
        return [min(balancing['current_a'], current) if v - lowest > balancing['threshold_v'] else 0.0
                for v in voltages]

    def _heat(self, group, power_per_cell_w, dt_s):
        """Add ``power_per_cell_w`` held over ``dt_s`` to a group's lumped thermal mass (exact)."""
        p = self.params
        rise = power_per_cell_w / p.cell_heat_transfer_w_per_k
        group.temperature_c += rise * (1.0 - math.exp(-dt_s * p.cell_heat_transfer_w_per_k
                                                      / p.cell_heat_capacity_j_per_k))

    def _become_full(self):
        self.status = Status.FULL
        self.cell_current_a = 0.0

    def _disconnect(self, cut_off, status):
        """As the lumped pack's: no current flows, in any group (their voltages relaxed from this step on)."""
        for group in self.groups:
            group.cell_current_a = 0.0
        super()._disconnect(cut_off, status)

    # -- inputs -------------------------------------------------------------------------------

    def set_mode(self, mode):
        for group in self.groups:
            group.mode = mode
        super().set_mode(mode)

    def set_state(self, state_of_charge=None, temperature_c=None, state_of_health=None, gauge_error=None):
        """As BatteryModel's; a state of charge puts every group there (their SOC offsets cleared).
        ValueError, nothing changed, for a value out of range."""
        saved = [g._state() for g in self.groups]
        try:
            for group in self.groups:
                group.set_state(state_of_charge, temperature_c, state_of_health)
            self._sync()
            BatteryModel.set_state(self, state_of_charge, None, None, gauge_error)
        except ValueError:
            for group, state in zip(self.groups, saved):
                group._restore(state)
            self._sync()
            raise
        self._sync()

    def export_state(self):
        state = super().export_state()
        state['groups'] = [g.export_state() for g in self.groups]
        return state

    def _restore_groups(self, saved_groups):
        if isinstance(saved_groups, list) and len(saved_groups) == len(self.groups):
            for group, saved in zip(self.groups, saved_groups):
                try:
                    group.restore_state(saved)
                except ValueError:
                    pass   # that group resumes from the pack's values
        self._sync()
