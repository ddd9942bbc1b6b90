"""A fuel gauge that behaves like the ones robots carry (Part 9; no ROS): ``gauge: {model: learning}``.

TI's Impedance Track gauges (bq27z561, bq40z50) and Analog Devices' ModelGauge m5 (MAX17055, MAX17260)
count charge as a coulomb counter does (core/gauge.py: the sensor's offset and gain error, the capacity
belief, the deadband are kept), and besides:

- **Rest correction** (TI SLUA450A "OCV measurement"; MAX17055 datasheet "Relaxation"): while |current|
  stays below ``relax_current_a`` (C/20) for ``relax_time_s`` (1800 s) and the cell voltage moves less
  than ``relax_dvdt_v_per_s`` (4e-6 V/s per cell), the gauge reads the open-circuit voltage (less I x R0
  for the small current), converts it through its own OCV table (``gauge_ocv``: by default the mean of the
  model's charge and discharge branches, so a rest after a charge and after a discharge corrects with the
  hysteresis' error, as real gauges do) and sets its state of charge; again every
  ``rest_update_period_s`` (100 s) while the rest lasts. A rest cut short corrects nothing.
- **Learned capacity** (TI SLUA450A "Qmax update"; ModelGauge m5 guide "FullCapRep learning"): between
  two rest readings with at least ``learn_min_passed`` (37 %) of the design capacity passed (the first
  update: ``learn_first_min_passed``, 90 %), both at 10-40 degC, the full capacity becomes passed charge /
  the difference of the two readings' states of charge; also at a valid end of charge after a rest
  reading below 10 % or the cut-off (``learn_at_end_of_charge``: where the pack cut off is known, the
  unusable state of charge at that load and temperature). Each update moves at most ``capacity_update_limit``
  (10 %) of the last value.
- **End of charge** (TI SLUUCH2 "Charge termination"; MAX17055 "FullDet"): the percentage holds at 99 %
  until the average charge current has stayed below ``taper_current_a`` (1.1 x the charger's termination
  current; ModelGauge: between 0.125x and 1.25x, and its own estimate above 95 %) for two
  ``taper_window_s`` (40 s) windows with the cell voltage within ``taper_voltage_fraction`` (2 %) of the
  charge voltage; then 100 % (and FULL). A charger that terminates inside the taper completes the windows
  at zero current; a charge stopped above the taper current (contact lost early) leaves 99 %. The end of
  charge holds (FULL) until a current is counted below 99 %: a rest reading alone does not end it.
- **Zero holds** (``lock_zero``): once the gauge has shown 0 %, a rest that lets the voltage recover does
  not raise it until a charge (TI's RSOC at Terminate Voltage; MAX17055's empty compensation).
- **Remaining capacity for the present load and temperature** (TI SLUUCD5 "RemainingCapacity"): the gauge
  runs its own model of the pack (the model's OCV discharge branch, its resistances with their SOC and
  temperature dependence, its RC pairs and its heating) forward at the averaged discharge load from its
  state of charge to the cut-off voltage. What lies below that point is unusable now:

      unusable soc u (recomputed when the load, the temperature or the state of charge moved)
      full charge capacity  FCC = Q_max (1 - u)          (BatteryState.capacity)
      remaining capacity    RM  = Q_max (soc - u)          (BatteryState.charge, the time remaining)
      percentage            RM / FCC, held at 99 % until the end of charge, 0 % held until a charge

``Q_max`` (the learned capacity) is ``capacity_ah``, the diagnostics' ``Gauge Full Capacity (Ah)`` and the
replay's ``gauge_full_capacity_ah``. Every correction is a GaugeEvent; core/battery.py logs the ones larger
than one point and counts them (``Gauge Corrections``).
"""
import math
from collections import namedtuple

from battery_simulator.core.gauge import (CAPACITY_LEARNED, END_OF_CHARGE, LEARNING_DEFAULTS, LOGGED_CORRECTION,
                                         OCV_REST, CoulombCounter)
from battery_simulator.core.parameter_rules import is_number

KELVIN = 273.15
#: the cut-off's correction (not one of EVENT_KINDS: the truth's cut-off, not the gauge's rule)
CUT_OFF = 'cut_off'
#: the percentage a gauge holds until its own end of charge
HOLD_BEFORE_FULL = 0.99

#: one correction: its kind, the value before and after (percentage, or Ah for a capacity), its size
#: (points, or % of the old capacity) and why
GaugeEvent = namedtuple('GaugeEvent', 'kind old new size reason')

#: a learned capacity comes from rest readings at least this far apart in state of charge
MIN_READING_SPAN = 0.05
#: end of charge learning starts from a rest reading (or the cut-off) below this state of charge
LEARN_AT_END_OF_CHARGE_BELOW = 0.10
#: the remaining capacity is recomputed when the averaged load moved by this fraction, the temperature by
#: this many K, or the state of charge by this much, at most every RECOMPUTE_AFTER_S of battery time (at once
#: when a load comes or goes, a rest is read or the capacity learned): TI's gauges too update their
#: remaining capacity now and then, not at every sample
RECOMPUTE_LOAD, RECOMPUTE_TEMPERATURE_K, RECOMPUTE_SOC = 0.1, 2.0, 0.1
RECOMPUTE_AFTER_S = 60.0
#: the forward run's step, state of charge; within NEAR_CUTOFF_V of the cut-off a finer one (measured on
#: lg_hg2_3s1p at 1C: the -10 degC loss shown is 96 % of the model's with 0.01 throughout, 100.8 % with
#: these, in 0.11 ms of CPU from 90 % at 1.5 A; 0.01 and 0.0025 within 0.3 V: 100.5 %, 0.15 ms)
FORWARD_STEP, FORWARD_STEP_NEAR_CUTOFF, NEAR_CUTOFF_V = 0.02, 0.0025, 0.25


def ocv_table(params, which):
    """The gauge's OCV table (cell voltages on ``params.ocv_soc``) for a gauge_ocv value."""
    discharge = list(params.ocv_voltage_v)
    charge = list(params.ocv_charge_voltage_v) or discharge
    if which == 'discharge':
        return discharge
    if which == 'charge':
        return charge
    if which == 'mean':
        return [0.5 * (c + d) for c, d in zip(charge, discharge)]
    return [float(v) for v in which]


class LearningGauge(CoulombCounter):
    """The config's ``gauge: {model: learning, ...}`` (see the module's docstring)."""

    __slots__ = ('settings', 'params', 'cells_series', 'cells_parallel', 'design_capacity_ah', 'relax_current_a',
                 'taper_current_a', 'taper_current_min_a', 'taper_voltage_v', 'ocv', 'full', 'zero_locked', 'learned',
                 'corrections', 'average_load_a', 'unusable', '_busy_charge_a', '_discharge_ocv', '_resistances',
                 '_events', '_rest_s', '_since_reading_s', '_last_cell_v', '_taper_s', '_reading', '_counted_as',
                 '_reading_counted_as', '_charge_start', '_start_counted_as',
                 '_unusable_for', '_unusable_loaded', '_since_unusable_s', '_average_dt', '_average_decay', '_watching',
                 '_shown', '_model')
    watches_rests = True

    def __init__(self, config, true_capacity_ah, true_soc, model):
        """``model``: the pack (core/battery_model.py) whose OCV and resistance tables the gauge takes as
        its own model of the pack."""
        super().__init__(config, true_capacity_ah, true_soc)
        params = model.params
        settings = dict(LEARNING_DEFAULTS)
        settings.update({key: config[key] for key in LEARNING_DEFAULTS if key in config})
        self.settings = settings
        self.params = params
        self.cells_series, self.cells_parallel = params.cells_series, params.cells_parallel
        self.design_capacity_ah = params.design_capacity_ah
        termination_a = params.pack_termination_current_a
        self.relax_current_a = settings['relax_current_a'] if settings['relax_current_a'] is not None \
            else params.design_capacity_ah / 20.0
        self.taper_current_a = settings['taper_current_a'] if settings['taper_current_a'] is not None \
            else settings['taper_current_factor'] * termination_a
        self.taper_current_min_a = settings['taper_current_min_factor'] * termination_a
        self._busy_charge_a = max(self.taper_current_a, self.relax_current_a)   # above it: no rest, no taper
        self.taper_voltage_v = (1.0 - settings['taper_voltage_fraction']) * params.cell_charge_voltage_v
        self.ocv = type(model.ocv)(params.ocv_soc, ocv_table(params, settings['gauge_ocv']))
        self._discharge_ocv = model.ocv
        self._resistances = model._resistances
        self.full = self.soc >= 1.0          # the end of charge was seen (100 % may show)
        self.zero_locked = False             # 0 % shown: held until a charge
        self.learned = False                 # the capacity has been updated at least once
        self.corrections = 0                 # corrections larger than LOGGED_CORRECTION
        self._events = ()                    # the corrections not taken yet (a tuple: none is the empty one)
        self._rest_s = 0.0                   # how long |current| has stayed below relax_current_a
        self._since_reading_s = None         # since this rest's last reading (None: none yet)
        self._last_cell_v = None
        self._taper_s = 0.0                  # how long the charge has been in the taper (or ended in it)
        self._reading = None                 # (soc, temperature ok) of the last rest reading
        self._counted_as = 0.0               # the measured charge counted since start, A*s (pack)
        self._reading_counted_as = 0.0       # ... at the last rest reading: the charge passed since is the difference
        self._charge_start = None            # (soc, temperature ok, a rest) the end of charge learns from: the
        #                                      last rest reading or cut-off (where the pack cuts off is known)
        self._start_counted_as = 0.0         # ... and _counted_as then
        self.average_load_a = 0.0            # the discharge current averaged (a rest or a charge: none)
        self.unusable = 0.0
        self._unusable_for = None            # (load, temperature, soc, capacity) the unusable soc is for
        self._unusable_loaded = False        # ... and whether that load was one (not a rest)
        self._since_unusable_s = 0.0         # since it was computed
        self._average_dt = None              # the step the load average's weight is for
        self._average_decay = 0.0            # the weight of the old average over that step
        self._watching = False               # the rest and taper watch ran since the last discharge
        self._shown = None                   # the reading since the last step (None: to compute)
        self._model = model

    # -- what the model calls ------------------------------------------------------------------

    def after_step(self, model, charge_as, dt_s, status_before):
        # the model calls this at every step (a fleet host: for each robot ten times a second): the discharge's
        # path does no more than count, average the load and look at the clock; the rest and taper watch run
        # only while the current is small or a charge tapers. (``model`` is the pack the gauge was made with.)
        if dt_s > 0.0:
            measured = charge_as * (1.0 + self.current_gain_error) + self.current_offset_a * dt_s
            deadband = self.deadband_a * dt_s
            if -deadband <= measured <= deadband:
                current = 0.0   # within the deadband: nothing counted
            else:
                soc = self.soc + measured / self.capacity_as
                self.soc = 0.0 if soc < 0.0 else (1.0 if soc > 1.0 else soc)
                self._counted_as += measured
                current = measured / dt_s
            if dt_s != self._average_dt:   # steps mostly repeat their length
                self._average_dt = dt_s
                self._average_decay = math.exp(-dt_s / self.settings['load_average_s'])
            if current < 0.0:
                average_a = self.average_load_a = -current + (self.average_load_a + current) * self._average_decay
                if self.full:
                    self._below_the_hold()
            else:
                average_a = self.average_load_a = self.average_load_a * self._average_decay   # no load: it decays
                if current > 0.0:
                    if self.zero_locked:
                        self.zero_locked = False    # a charge releases 0 %
                    if self.full:
                        self._below_the_hold()
            relax_a = self.relax_current_a
            if current <= -relax_a or current >= self._busy_charge_a:
                # a discharge, or a charge above the taper: no rest, no taper (the cheap way)
                if self._watching:
                    self._rest_s, self._since_reading_s, self._taper_s, self._last_cell_v = 0.0, None, 0.0, None
                    self._watching = False
            else:
                self._watching = True
                cell_v = model.voltage_v / self.cells_series
                self._watch_taper(current, model, cell_v, dt_s)
                self._watch_rest(current, cell_v, dt_s, model.temperature_c)
                self._last_cell_v = cell_v
            since_s = self._since_unusable_s = self._since_unusable_s + dt_s
            if since_s >= RECOMPUTE_AFTER_S or (average_a >= relax_a) is not self._unusable_loaded \
                    or self._unusable_for is None:
                self._refresh_unusable(model.temperature_c)
            if current < 0.0 and self.soc <= self.unusable and not self.zero_locked and self.settings['lock_zero']:
                self.zero_locked = True
        elif self._unusable_for is None:
            self._refresh_unusable(model.temperature_c)
        status = model.status
        if status is not status_before:
            if status.name == 'EMPTY' and model.cut_off is not None and model.cut_off.name == 'UNDER_VOLTAGE':
                self._at_cut_off()
            elif status.name == 'FULL' and not self.full and dt_s > 0.0:
                # the charger ended the charge itself: at its termination current, below the taper current, which
                # a gauge sampling once a second sees in the band before the current stops; the model's step may
                # end the charge above it (a pack filled first, an aged one: 0.18 A against a 0.055 A taper), and
                # then the gauge held 99 % on the dock for ever. A charge cut short (contact lost) is no Full.
                self._taper_s = max(self._taper_s, dt_s)
        self._shown = None   # the reading is computed again when asked

    def reading(self):
        """(percentage, remaining capacity Ah, full charge capacity Ah): see the module's docstring. Computed
        once after each step (the model asks twice: the percentage, and the charge for the time remaining)."""
        shown = self._shown
        if shown is None:
            usable = 1.0 - self.unusable
            full_ah = self.capacity_as / 3600.0 * usable
            fraction = self._fraction(usable)
            shown = self._shown = (100.0 * fraction, fraction * full_ah, full_ah)
        return shown

    @property
    def fraction(self):
        """The percentage shown, 0-1."""
        return self._fraction(1.0 - self.unusable)

    def _fraction(self, usable):
        if self.zero_locked:
            return 0.0
        fraction = (self.soc - self.unusable) / usable
        fraction = 0.0 if fraction < 0.0 else (1.0 if fraction > 1.0 else fraction)
        return fraction if self.full else min(fraction, HOLD_BEFORE_FULL)

    @property
    def charge_ah(self):
        return self.reading()[1]

    def save(self, state):
        state['gauge_soc'] = self.soc
        state['gauge_capacity_ah'] = self.capacity_as / 3600.0
        state['gauge_learned'] = self.learned
        state['gauge_zero_locked'] = self.zero_locked
        state['gauge_full'] = self.full

    def restore(self, saved):
        """As a real gauge resumes from its flash: its state of charge, the full capacity it learned (a
        positive number), whether it learned it, its zero lock and its end of charge (booleans); a value
        missing or of the wrong kind leaves that one as the gauge started."""
        super().restore(saved)
        capacity_ah = saved.get('gauge_capacity_ah')
        if is_number(capacity_ah) and capacity_ah > 0.0:
            self.capacity_as = float(capacity_ah) * 3600.0
        for key, name in (('gauge_learned', 'learned'), ('gauge_zero_locked', 'zero_locked'), ('gauge_full', 'full')):
            if isinstance(saved.get(key), bool):
                setattr(self, name, saved[key])
        self._unusable_for = None   # for the capacity and state of charge resumed
        self._shown = None

    def restart(self):
        self._rest_s, self._since_reading_s, self._last_cell_v, self._taper_s = 0.0, None, None, 0.0
        self._reading = self._charge_start = None
        self.zero_locked = False
        self.full = self.soc >= 1.0
        self._unusable_for = None
        self._shown = None
        if self._model is not None:
            self._refresh_unusable(self._model.temperature_c)

    def add_error(self, points):
        super().add_error(points)
        self.full = self.soc >= 1.0
        self._shown = None

    def on_full(self):
        """The truth's Full does not make a learning gauge show 100 %: its own end of charge does."""

    def on_empty(self):
        self._at_cut_off()

    def take_events(self):
        events = self._events
        if events:
            self._events = ()
        return events

    # -- the rules --------------------------------------------------------------------------------

    def _below_the_hold(self):
        """While a current is counted: below the hold, the end of charge is over (the next 100 % needs another).
        A rest reading alone does not end it: an imbalanced pack on its charger reads a little less than full
        through its groups' mean voltage (FULL, not CHARGING with no current)."""
        if self.soc - self.unusable < HOLD_BEFORE_FULL * (1.0 - self.unusable):
            self.full = False

    def _watch_taper(self, current, model, cell_v, dt_s):
        """Two taper windows in a row near the charge voltage: the end of charge. The voltage is the highest
        group's, which the BMS holds at the charge voltage (``cell_v``, the mean, in a lumped pack): a pack
        whose groups differ ends its charge with the others lower."""
        if current < 0.0 or self.full:
            self._taper_s = 0.0
            return
        groups = getattr(model, 'groups', None)
        if groups:
            cell_v = max(group.cell_voltage_v for group in groups)
        if cell_v < self.taper_voltage_v:
            self._taper_s = 0.0
            return
        if current > 0.0:
            in_taper = self.taper_current_min_a <= current < self.taper_current_a
        else:   # the charger stopped: inside the taper only if it had got there (it terminated in the band:
            # ModelGauge's lower bound, 0.125 x IChgTerm, is for a charge current, not the charger's end)
            in_taper = self._taper_s > 0.0
        self._taper_s = self._taper_s + dt_s if in_taper else 0.0
        if self._taper_s >= self.settings['taper_windows'] * self.settings['taper_window_s'] \
                and self.soc >= self.settings['end_of_charge_min_soc']:
            self._end_of_charge()

    def _end_of_charge(self):
        old = self.fraction
        temperature_c = self._model.temperature_c if self._model is not None else None
        start, passed_as = self._charge_start, self._counted_as - self._start_counted_as
        if self.settings['learn_capacity'] and self.settings['learn_at_end_of_charge'] and start is not None \
                and start[0] < LEARN_AT_END_OF_CHARGE_BELOW and start[1] and self._temperature_ok(temperature_c) \
                and passed_as >= self._min_passed_as():
            self._learn(passed_as / 3600.0 / (1.0 - start[0]), 'end of charge after %s at %.1f %%'
                        % ('a rest reading' if start[2] else 'the cut-off', 100.0 * start[0]))
            self._reading = self._charge_start = None   # that pair is used
        self.soc = 1.0
        self.full = True
        self.zero_locked = False
        self._taper_s = 0.0
        # the step from the hold to 100 % is the end of charge itself, not a correction: its size is what
        # the gauge read below the hold
        self._event(END_OF_CHARGE, 100.0 * old, 100.0 * self.fraction,
                    'end of charge: the charge current stayed below %.3f A for %g s near the charge voltage'
                    % (self.taper_current_a, self.settings['taper_windows'] * self.settings['taper_window_s']),
                    size=max(0.0, 100.0 * (HOLD_BEFORE_FULL - old)))

    def _watch_rest(self, current, cell_v, dt_s, temperature_c):
        """A long and settled rest: the open-circuit voltage sets the state of charge."""
        if not -self.relax_current_a < current < self.relax_current_a:
            self._rest_s, self._since_reading_s = 0.0, None
            return
        self._rest_s += dt_s
        if self._since_reading_s is not None:
            self._since_reading_s += dt_s
        if self._rest_s < self.settings['relax_time_s'] or self._last_cell_v is None:
            return
        if abs(cell_v - self._last_cell_v) >= self.settings['relax_dvdt_v_per_s'] * dt_s:
            return
        if self._since_reading_s is not None and self._since_reading_s < self.settings['rest_update_period_s']:
            return
        self._since_reading_s = 0.0
        self._rest_reading(current, cell_v, temperature_c)

    def _rest_reading(self, current, cell_v, temperature_c):
        r0 = self._resistances.r0_at(self.soc, current > 0.0) * self._resistance_scale(temperature_c)
        open_circuit_v = cell_v - current / self.cells_parallel * r0
        soc = self.ocv.soc(open_circuit_v)
        old = self.fraction
        temperature_ok = self._temperature_ok(temperature_c)
        reading = self._reading
        passed_as = abs(self._counted_as - self._reading_counted_as)
        if self.settings['learn_capacity'] and reading is not None and reading[1] and temperature_ok \
                and passed_as >= self._min_passed_as() and abs(soc - reading[0]) >= MIN_READING_SPAN:
            self._learn(passed_as / 3600.0 / abs(soc - reading[0]),
                        'rest readings at %.1f %% and %.1f %% with %.3f Ah passed'
                        % (100.0 * reading[0], 100.0 * soc, passed_as / 3600.0))
        self._reading = (soc, temperature_ok)
        self._charge_start = (soc, temperature_ok, True)
        self._reading_counted_as = self._start_counted_as = self._counted_as
        self.soc = soc
        self._unusable_for = None
        self._refresh_unusable(temperature_c)
        new = self.fraction
        if abs(new - old) >= 0.0005:
            self._event(OCV_REST, 100.0 * old, 100.0 * new, 'rest of %.0f min: open-circuit %.3f V per cell is '
                        '%.1f %%' % (self._rest_s / 60.0, open_circuit_v, 100.0 * soc))

    def _min_passed_as(self):
        share = self.settings['learn_min_passed'] if self.learned else self.settings['learn_first_min_passed']
        return share * self.design_capacity_ah * 3600.0

    def _temperature_ok(self, temperature_c):
        return temperature_c is not None and \
            self.settings['learn_temperature_min_c'] <= temperature_c <= self.settings['learn_temperature_max_c']

    def _learn(self, capacity_ah, why):
        old_ah = self.capacity_as / 3600.0
        limit = self.settings['capacity_update_limit']
        new_ah = min(max(capacity_ah, old_ah * (1.0 - limit)), old_ah * (1.0 + limit))
        self.capacity_as = new_ah * 3600.0
        self.learned = True
        self._unusable_for = None
        self._event(CAPACITY_LEARNED, old_ah, new_ah, 'full capacity learned from %s: %.3f Ah%s'
                    % (why, capacity_ah, '' if new_ah == capacity_ah else ' (limited to %g %% a step)'
                       % (100.0 * limit)), size=100.0 * abs(new_ah - old_ah) / old_ah)

    def _at_cut_off(self):
        old = self.fraction
        # where the pack cuts off is known (the unusable state of charge at this load and temperature): a start
        # for the end of charge's learning (a discharge from below 10 %), though not a rest reading of a pair
        temperature_c = self._model.temperature_c if self._model is not None else None
        self._charge_start = (self.unusable, self._temperature_ok(temperature_c), False)
        self._start_counted_as = self._counted_as
        self.soc = min(self.soc, self.unusable)
        self.zero_locked = bool(self.settings['lock_zero'])
        if not self.zero_locked:
            self.soc = self.unusable
        self._shown = None
        self._event(CUT_OFF, 100.0 * old, 0.0, 'the pack cut off at its cut-off voltage')

    def _event(self, kind, old, new, reason, size=None):
        size = abs(new - old) if size is None else size
        event = GaugeEvent(kind, old, new, size, reason)
        if size > LOGGED_CORRECTION:
            self.corrections += 1
        self._events += (event,)
        if len(self._events) > 100:   # nobody takes them (a model without a front end): keep the latest
            self._events = self._events[50:]

    # -- remaining capacity ------------------------------------------------------------------------

    def _refresh_unusable(self, temperature_c):
        """Recompute the unusable state of charge if what it is for moved (looked at every RECOMPUTE_AFTER_S,
        and at once when a load came or went)."""
        self._since_unusable_s = 0.0
        load_a, soc, capacity_as = self.average_load_a, self.soc, self.capacity_as
        if load_a < self.relax_current_a:
            load_a = 0.0    # at rest (or charging): the open-circuit voltage's end
        last = self._unusable_for
        if last is not None and (load_a == 0.0) != (last[0] == 0.0):
            last = None   # a load came or went: at once
        if last is not None and abs(load_a - last[0]) <= RECOMPUTE_LOAD * last[0] \
                and abs(temperature_c - last[1]) <= RECOMPUTE_TEMPERATURE_K and abs(soc - last[2]) <= RECOMPUTE_SOC \
                and capacity_as == last[3]:
            return
        self._unusable_for = (load_a, temperature_c, soc, capacity_as)
        self._unusable_loaded = load_a > 0.0
        self.unusable = self.unusable_soc(load_a, temperature_c, soc)

    def unusable_soc(self, load_a, temperature_c, soc):
        """The state of charge at which the pack reaches its cut-off voltage when it delivers ``load_a``
        (A, pack) from ``soc`` at ``temperature_c``: the gauge's own model run forward (discharge branch,
        the model's resistances at their SOC and temperature, its RC pairs from their state now, its
        heating towards the ambient temperature)."""
        p = self._model.params if self._model is not None else self.params
        current = load_a / self.cells_parallel
        if soc <= 0.0:
            return 0.0
        if not current > 0.0:
            return self._discharge_ocv.soc(p.cell_cutoff_voltage_v) if soc > 0.0 else 0.0
        cutoff_v = p.cell_cutoff_voltage_v
        capacity_as = self.capacity_as / self.cells_parallel
        v1, v_fast = self._rc_voltages()
        heat_capacity, transfer = p.cell_heat_capacity_j_per_k, p.cell_heat_transfer_w_per_k
        ambient_c = p.ambient_temperature_c
        fast = p.r_fast_ohm > 0.0

        def decays(step):
            dt_s = step * capacity_as / current
            return (step, math.exp(-dt_s / p.tau1_s), math.exp(-dt_s / p.tau_fast_s) if fast else 0.0,
                    math.exp(-dt_s * transfer / heat_capacity))
        coarse, fine = decays(FORWARD_STEP), decays(FORWARD_STEP_NEAR_CUTOFF)
        previous = None
        while True:
            r0, r1, r_fast = self._resistances.at(soc, False)
            scale = self._resistance_scale(temperature_c)
            voltage = self._discharge_ocv.voltage(soc) - current * r0 * scale - v1 - v_fast
            if voltage <= cutoff_v:
                if previous is None:
                    return soc
                soc_before, voltage_before = previous
                return soc + (soc_before - soc) * (cutoff_v - voltage) / (voltage_before - voltage)
            if soc <= 0.0:
                return 0.0
            previous = (soc, voltage)
            step, decay1, decay_fast, thermal = coarse if voltage > cutoff_v + NEAR_CUTOFF_V else fine
            v1 = current * r1 * scale + (v1 - current * r1 * scale) * decay1
            if fast:
                v_fast = current * r_fast * scale + (v_fast - current * r_fast * scale) * decay_fast
            heat_w = current * (current * r0 * scale + v1 + v_fast)
            settled_c = ambient_c + heat_w / transfer
            temperature_c = settled_c + (temperature_c - settled_c) * thermal
            soc = max(0.0, soc - step)

    def _rc_voltages(self):
        """The discharge's RC voltages now, per cell, as positive drops (0 while charging or unknown)."""
        model = self._model
        if model is None:
            return 0.0, 0.0
        groups = getattr(model, 'groups', None) or (model,)
        v1 = -sum(g.rc_voltage_v for g in groups) / len(groups)
        v_fast = -sum(g.fast_rc_voltage_v for g in groups) / len(groups)
        return max(v1, 0.0), max(v_fast, 0.0)

    def _resistance_scale(self, temperature_c):
        p = self.params
        if not p.arrhenius_temperature_k:
            return 1.0
        return math.exp(p.arrhenius_temperature_k * (
            1.0 / (temperature_c + KELVIN) - 1.0 / (p.reference_temperature_c + KELVIN)))
