"""The pack's fuel gauge: what a robot reads as its percentage, which need not be the truth (no ROS).

A coulomb-counting gauge integrates the current its sensor measures, with an
offset and a gain error, into the capacity it believes (which lags the pack's
ageing and may be wrong from the start). It recalibrates at the end of a charge
(it calls that 100 %) and at the cut-off (0 %), which is where a robot sees it
jump. The model keeps the truth; battery_status, the action's feedback,
low/critical, the dashboard and predict show the gauge.

    measured current  I_m = I (1 + current_gain_error) + current_offset_a
    gauge charge      q  += I_m dt   (clamped to [0, believed capacity]; nothing while |I_m| <= deadband_a)
    believed capacity C_b = true capacity at start (1 + capacity_error)
    gauge percentage  100 q / C_b    (at start: the truth + initial_error, clamped to [0, 100])

The deadband is a real gauge's (TI's Impedance Track gauges call it "CC Deadband"): a measured
current within it counts as none, so that a sensor's offset does not move the gauge while no current
flows (a pack cut off, or full on its charger). Its default sits just above the sensor's offset:
``|current_offset_a|`` + DEFAULT_DEADBAND_A.
"""
from battery_simulator.core.parameter_rules import is_number

#: the keys of ``gauge: {model: learning, ...}`` besides the counter's, with their defaults (None: from
#: the pack: relax_current_a C/20, taper_current_a taper_current_factor x the termination current)
LEARNING_DEFAULTS = {
    'relax_current_a': None,
    'relax_time_s': 1800.0,
    'relax_dvdt_v_per_s': 4e-6,
    'rest_update_period_s': 100.0,
    'gauge_ocv': 'mean',
    'learn_capacity': True,
    'learn_min_passed': 0.37,
    'learn_first_min_passed': 0.90,
    'learn_temperature_min_c': 10.0,
    'learn_temperature_max_c': 40.0,
    'learn_at_end_of_charge': True,
    'capacity_update_limit': 0.1,
    'taper_current_a': None,
    'taper_current_factor': 1.1,
    'taper_current_min_factor': 0.0,
    'taper_window_s': 40.0,
    'taper_windows': 2,
    'taper_voltage_fraction': 0.02,
    'end_of_charge_min_soc': 0.0,
    'lock_zero': True,
    'load_average_s': 20.0,
}
#: the corrections a learning gauge names (battery_replay's gauge_event column)
OCV_REST, CAPACITY_LEARNED, END_OF_CHARGE = 'ocv_rest', 'capacity_learned', 'end_of_charge'
EVENT_KINDS = (OCV_REST, CAPACITY_LEARNED, END_OF_CHARGE)
#: a correction larger than this (percentage points; a capacity change in % of the old value) is logged
#: once and counted (the diagnostics' Gauge Corrections)
LOGGED_CORRECTION = 1.0
#: the deadband above the sensor's offset when the config gives none, A (a few mA, as gauges ship)
DEFAULT_DEADBAND_A = 0.005
#: what a gauge keeps across a restart (a real gauge's flash) in the model's saved state (core/battery_model.py's
#: export_state, the state_file): its belief of the state of charge; a learning gauge also its learned full
#: capacity (Ah, pack), whether it has learned it, its zero lock and whether it has seen its end of charge.
#: A state saved without them (an older file, another gauge) resumes those as configured.
SAVED_KEYS = ('gauge_soc', 'gauge_capacity_ah', 'gauge_learned', 'gauge_zero_locked', 'gauge_full')


#: a gauge that recalibrates at full counts up to this and no further: it shows 100 % when the charge
#: terminates (on_full), not while the charge current still flows because its count got there first (a
#: gauge ahead of the truth, or believing too little capacity). TI's Impedance Track gauges do the same:
#: RelativeStateOfCharge is held at 99 % until they detect the taper's end (the FC flag).
HOLD_BEFORE_FULL = 0.99


class CoulombCounter:
    """A coulomb-counting gauge (the config's ``gauge: {model: coulomb_counter, ...}``)."""

    # slots: a fleet host keeps hundreds of gauges and steps each ten times a second (attributes in slots are
    # read without a dictionary, and the gauge's state stays together in memory)
    __slots__ = ('current_offset_a', 'current_gain_error', 'capacity_error', 'deadband_a', 'recalibrate_at_full',
                 'recalibrate_at_empty', 'capacity_as', 'soc')
    #: whether the gauge looks at the voltage while the pack rests (a learning gauge's rest reading): a rest
    #: is then stepped as the gauge samples it, not in one exact step (battery_replay)
    watches_rests = False
    #: what a learning gauge adds to the diagnostics (core/battery_record.py's GaugeSummary): a coulomb counter
    #: makes no corrections, learns nothing and does not watch its own end of charge
    corrections, learned, full = 0, False, None

    def __init__(self, config, true_capacity_ah, true_soc):
        """``true_capacity_ah``: the pack's capacity at start (aged as configured), which the gauge believes
        ``capacity_error`` wrong; ``true_soc``: its state of charge then, which it believes ``initial_error``
        points wrong (clamped to 0-100 %: a belief, not an invalid value)."""
        self.current_offset_a = float(config.get('current_offset_a', 0.0))
        self.current_gain_error = float(config.get('current_gain_error', 0.0))
        self.capacity_error = float(config.get('capacity_error', 0.0))
        self.deadband_a = float(config.get('deadband_a', abs(self.current_offset_a) + DEFAULT_DEADBAND_A))
        self.recalibrate_at_full = bool(config.get('recalibrate_at_full', True))
        self.recalibrate_at_empty = bool(config.get('recalibrate_at_empty', True))
        self.capacity_as = true_capacity_ah * 3600.0 * (1.0 + self.capacity_error)   # believed, pack A*s
        soc = true_soc + float(config.get('initial_error', 0.0)) / 100.0
        self.soc = 0.0 if soc < 0.0 else (1.0 if soc > 1.0 else soc)

    def count(self, charge_as, dt_s):
        """The pack took ``charge_as`` (A*s, positive charging) over ``dt_s``: count what the sensor saw
        (its mean current over the step; nothing within the deadband). A gauge that recalibrates at full
        counts up to HOLD_BEFORE_FULL only: 100 % is the charge's end."""
        if not dt_s > 0.0:
            return
        measured = charge_as * (1.0 + self.current_gain_error) + self.current_offset_a * dt_s
        if -self.deadband_a * dt_s <= measured <= self.deadband_a * dt_s:
            return
        soc = self.soc + measured / self.capacity_as
        if measured > 0.0 and self.recalibrate_at_full and soc > HOLD_BEFORE_FULL:
            soc = max(self.soc, HOLD_BEFORE_FULL)   # never up past it by counting (nor down by the hold)
        self.soc = 0.0 if soc < 0.0 else (1.0 if soc > 1.0 else soc)

    def after_step(self, model, charge_as, dt_s, status_before):
        """The model has stepped ``dt_s`` and the pack took ``charge_as`` (A*s, pack): count it, and
        recalibrate where the pack's status changed to Full (the charge's end) or Empty (the cut-off)."""
        self.count(charge_as, dt_s)   # (nothing for a step of 0 s)
        status = model.status
        if status is not status_before:
            if status.name == 'FULL':
                self.on_full()
            elif status.name == 'EMPTY' and model.cut_off is not None and model.cut_off.name == 'UNDER_VOLTAGE':
                self.on_empty()

    def reading(self):
        """(percentage, charge Ah, capacity Ah) as the gauge reports them."""
        return 100.0 * self.soc, self.charge_ah, self.capacity_ah

    def save(self, state):
        """Add what survives a restart to the model's saved ``state`` (SAVED_KEYS)."""
        state['gauge_soc'] = self.soc

    def restore(self, saved):
        """Take back what save() kept, from the model's saved state; a value missing or out of range leaves
        the gauge as it started (the truth, or the configured belief)."""
        soc = saved.get('gauge_soc')
        if is_number(soc) and 0.0 <= soc <= 1.0:
            self.soc = float(soc)

    def restart(self):
        """set_state moved the pack: a gauge that watches rests and tapers starts watching anew."""

    def take_events(self):
        """The corrections since the last call (a coulomb counter names none): [GaugeEvent]."""
        return ()

    def on_full(self):
        if self.recalibrate_at_full:
            self.soc = 1.0

    def on_empty(self):
        if self.recalibrate_at_empty:
            self.soc = 0.0

    def add_error(self, points):
        """``points`` percentage points added now; ValueError if that leaves 0-100 (nothing changed)."""
        soc = self.soc + points / 100.0
        if not 0.0 <= soc <= 1.0:
            raise ValueError('gauge_error = %r is invalid: it puts the gauge at %.1f %% (now %.1f %%): the '
                             'percentage must stay in [0, 100]' % (points, 100.0 * soc, 100.0 * self.soc))
        self.soc = soc

    @property
    def charge_ah(self):
        return self.soc * self.capacity_as / 3600.0

    @property
    def capacity_ah(self):
        return self.capacity_as / 3600.0

