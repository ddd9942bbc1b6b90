"""Battery parameters: units, defaults, validation and YAML presets (no rospy).

A pack is ``cells_series`` x ``cells_parallel`` identical cells. Cell values are
per cell; load and charger values are per pack, as a robot sees them.
"""
import math
from dataclasses import dataclass, fields, replace
from pathlib import Path

import yaml

from battery_simulator.core.lfp_tables import CHEMISTRIES, LIMITS, chemistry_tables


class ParameterError(ValueError):
    """A parameter value is out of its allowed range; the message names both."""


def _positive(value):
    return is_number(value) and value > 0


def _non_negative(value):
    return is_number(value) and value >= 0


def is_number(value):
    """A real, finite number (not a bool)."""
    return (isinstance(value, (int, float)) and not isinstance(value, bool)
            and math.isfinite(value))


def number_from_text(value):
    """A numeric string as a float ('1e9', ' 22 '); anything else as it is.

    roslaunch hands some numbers over as text (``time_scale:=1e9``), and so does
    PyYAML for a float without a dot (``1.0e6`` is a float, ``1e6`` is text).
    """
    if isinstance(value, str):
        try:
            return float(value.strip())
        except ValueError:
            pass
    return value


def _is_count(value):
    return isinstance(value, int) and not isinstance(value, bool) and value >= 1


@dataclass(frozen=True)
class BatteryParameters:
    """Every parameter of the battery model, with its unit in its name."""

    name: str = 'custom'
    #: cells in series (multiplies voltage and resistance)
    cells_series: int = 1
    #: strings in parallel (multiplies capacity and current, divides resistance)
    cells_parallel: int = 1
    #: cell capacity when new, Ah (charged CC-CV, discharged to cut-off)
    cell_capacity_ah: float = 2.78
    #: open-circuit voltage table: state of charge 0..1, strictly increasing
    ocv_soc: tuple = (0.0, 1.0)
    #: open-circuit voltage at each ``ocv_soc`` point, V per cell, increasing
    ocv_voltage_v: tuple = (2.8, 4.2)
    #: series (ohmic) resistance per cell at the reference temperature, ohm
    r0_ohm: float = 0.02
    #: RC-pair (polarisation) resistance per cell at the reference temperature, ohm
    r1_ohm: float = 0.015
    #: RC-pair time constant, s (with a fast pair beside it, this is the slow one: diffusion)
    tau1_s: float = 60.0
    #: a second, fast RC pair (charge transfer) per cell at the reference temperature, ohm (0 = none)
    r_fast_ohm: float = 0.0
    #: the fast RC pair's time constant, s
    tau_fast_s: float = 20.0
    #: SOC grid (0..1, strictly increasing) of the resistance factor tables; empty: no SOC dependence
    resistance_soc: tuple = ()
    #: r0_ohm is multiplied by these factors at the ``resistance_soc`` points (linear between); empty = 1
    r0_soc_factor: tuple = ()
    #: r1_ohm is multiplied by these factors at the ``resistance_soc`` points; empty = 1
    r1_soc_factor: tuple = ()
    #: r_fast_ohm is multiplied by these factors at the ``resistance_soc`` points; empty = 1
    r_fast_soc_factor: tuple = ()
    #: while charging r0 is multiplied by this as well (the discharge direction is 1)
    r0_charge_factor: float = 1.0
    #: while charging r1 is multiplied by this as well
    r1_charge_factor: float = 1.0
    #: while charging r_fast is multiplied by this as well
    r_fast_charge_factor: float = 1.0
    #: open-circuit voltage of the charge branch at each ``ocv_soc`` point, V per cell, at or above
    #: ``ocv_voltage_v`` (then the discharge branch); empty: one OCV curve for both directions
    ocv_charge_voltage_v: tuple = ()
    #: charge per cell that moves the OCV 63 % of the way from one branch to the other, Ah
    hysteresis_ah: float = 0.1
    #: fraction of the charge put in that is stored, 0 < eta <= 1
    coulombic_efficiency: float = 0.999
    #: constant-voltage limit per cell, V (above the OCV table's start, at most 0.05 V above its top)
    cell_charge_voltage_v: float = 4.2
    #: discharge cut-off per cell, V (the load is disconnected there)
    cell_cutoff_voltage_v: float = 2.8
    #: charger constant current per pack, A
    charge_current_a: float = 1.5
    #: CV taper end per pack, A; None means C/20 of the pack's design capacity
    termination_current_a: float = None
    #: base discharge current per pack, A
    load_current_a: float = 1.5
    #: constant-power discharge load per pack, W (adds I = P / V)
    load_power_w: float = 0.0
    #: ambient temperature, degC
    ambient_temperature_c: float = 25.0
    #: temperature at start; None means ambient, degC
    initial_temperature_c: float = None
    #: heat capacity per cell, J/K
    cell_heat_capacity_j_per_k: float = 45.0
    #: heat transfer from a cell to ambient, W/K
    cell_heat_transfer_w_per_k: float = 0.06
    #: Arrhenius activation temperature Ea/R of the resistances, K (0 = none)
    arrhenius_temperature_k: float = 2800.0
    #: temperature at which r0_ohm and r1_ohm hold, degC
    reference_temperature_c: float = 25.0
    #: maximum continuous discharge current per cell (datasheet), A: the protection cuts the load off above it
    cell_max_discharge_current_a: float = 20.0
    #: maximum charge current per cell (datasheet), A: the protection cuts the charger off above it
    cell_max_charge_current_a: float = 4.0
    #: the pack protection disconnects load and charger at this cell temperature, degC
    protection_temperature_c: float = 75.0
    #: health OVERHEAT above this cell temperature, degC
    overheat_temperature_c: float = 60.0
    #: health COLD below this cell temperature, degC
    cold_temperature_c: float = 0.0
    #: capacity lost per equivalent full cycle, fraction of design capacity
    capacity_fade_per_cycle: float = 0.0002
    #: equivalent full cycles the pack has done at start
    initial_cycle_count: float = 0.0
    #: motion load: drive power per m/s of |cmd_vel.linear.x|, W/(m/s)
    drive_power_w_per_mps: float = 0.0
    #: motion load: turning power per rad/s of |cmd_vel.angular.z|, W/(rad/s)
    turn_power_w_per_radps: float = 0.0
    #: a cmd_vel older than this counts as standing still, s
    cmd_vel_timeout_s: float = 0.5
    #: measurement_noise fault: standard deviation of the reported voltage, V
    voltage_noise_v: float = 0.02
    #: measurement_noise fault: standard deviation of the reported current, A
    current_noise_a: float = 0.05
    #: BatteryState.location
    location: str = 'base'
    #: BatteryState.serial_number
    serial_number: str = ''
    #: where the numbers come from
    source: str = ''
    #: the cells' chemistry: 'li-ion' (NMC / NCA) or 'lfp'; a config naming 'lfp' without an OCV table of
    #: its own gets LFP's (core/lfp_tables.py)
    chemistry: str = 'li-ion'
    #: a pack of differing cells (Part 5): relative standard deviation of the series groups' capacity and
    #: resistance, drawn with ``spread_seed`` (0: identical groups, the lumped model); below MAX_SPREAD
    capacity_spread: float = 0.0
    resistance_spread: float = 0.0
    spread_seed: int = 0
    #: or each group given: ({capacity_factor, resistance_factor, initial_soc_offset}, ...), cells_series long
    groups: tuple = ()
    #: passive balancing {current_a, start_voltage_v, threshold_v} (per group; None: no balancing)
    balancing: dict = None
    #: the diagnostics warn when the cell voltages differ by more than this, V
    imbalance_warn_v: float = 0.05
    #: the fuel gauge: None or {model: ideal} (the percentage is the truth) or {model: coulomb_counter,
    #: current_offset_a, current_gain_error, capacity_error, initial_error, deadband_a, recalibrate_at_full,
    #: recalibrate_at_empty}
    gauge: dict = None
    #: a full pack on the dock is held full (Part 7): once the charge has ended the connected charger tops
    #: up what the robot's own load draws (load_current_a, load_power_w, payloads, motion) as it draws it,
    #: so the pack stays at 100 % and battery_status shows that current as charge (status FULL), as docks
    #: that power the robot through its pack do (opennav_docking's SimpleChargingDock calls > 0.5 A
    #: charging). false: the charger switches off at Full and a full pack on the dock shows 0 A
    charger_holds_full: bool = True
    #: how a driver's BatteryState reads, to test a consumer against drivers that invert conventions:
    #: None or {invert_current_sign: false, percentage_scale: 1}; true / 100 give Gazebo's
    #: invert_current_sign and 0-100 percentages on battery_status (the model and battery_simulator/state
    #: keep the package's own conventions)
    conventions: dict = None

    def __post_init__(self):
        validate(self)

    @property
    def design_capacity_ah(self):
        """Pack capacity when new, Ah."""
        return self.cell_capacity_ah * self.cells_parallel

    @property
    def max_discharge_current_a(self):
        """The most current the pack may deliver (its cells' datasheet current), A."""
        return self.cell_max_discharge_current_a * self.cells_parallel

    @property
    def max_discharge_power_w(self):
        """The most power the pack can ever deliver, W: its datasheet current at its full voltage."""
        return (self.cell_max_discharge_current_a * self.cells_parallel
                * self.cell_charge_voltage_v * self.cells_series)

    def motion_power_w(self, speed_mps, turn_radps):
        """The motion load of a robot driving at ``speed_mps`` and turning at ``turn_radps`` (either sign), W."""
        return self.drive_power_w_per_mps * abs(speed_mps) + self.turn_power_w_per_radps * abs(turn_radps)

    @property
    def has_groups(self):
        """Whether the pack is modelled group by group (a spread, given groups or balancing)."""
        return bool(self.capacity_spread or self.resistance_spread or self.groups or self.balancing)

    @property
    def pack_termination_current_a(self):
        """The CV taper end per pack, A (C/20 unless set)."""
        if self.termination_current_a is None:
            return self.design_capacity_ah / 20.0
        return self.termination_current_a


#: the most cells in series or in parallel a config may ask for
MAX_CELLS = 200
#: measurement_noise sigmas: a sensor noisier than this measures nothing
MAX_VOLTAGE_NOISE_V = 1.0
MAX_CURRENT_NOISE_A = 5.0
#: drive / turn power per unit of speed: 10 kW per m/s is already a car's drive train
MAX_MOTION_POWER_COEFFICIENT = 10000.0
#: a speed or turn rate beyond these is no robot's (cmd_vel ignores it, prediction refuses it)
MAX_SPEED_MPS = 50.0
MAX_TURN_RADPS = 50.0

# (parameter, check, what is allowed); checked in this order.
_RULES = (
    ('name', lambda v: isinstance(v, str) and v != '', 'a non-empty string'),
    ('cells_series', lambda v: _is_count(v) and v <= MAX_CELLS, 'a whole number in [1, %d]' % MAX_CELLS),
    ('cells_parallel', lambda v: _is_count(v) and v <= MAX_CELLS, 'a whole number in [1, %d]' % MAX_CELLS),
    ('cell_capacity_ah', _positive, 'a number > 0'),
    ('r0_ohm', _positive, 'a number > 0'),
    ('r1_ohm', _non_negative, 'a number >= 0'),
    ('tau1_s', _positive, 'a number > 0'),
    ('r_fast_ohm', _non_negative, 'a number >= 0'),
    ('tau_fast_s', _positive, 'a number > 0'),
    ('r0_charge_factor', _positive, 'a number > 0'),
    ('r1_charge_factor', _positive, 'a number > 0'),
    ('r_fast_charge_factor', _positive, 'a number > 0'),
    ('hysteresis_ah', _positive, 'a number > 0'),
    ('coulombic_efficiency', lambda v: is_number(v) and 0 < v <= 1, 'a number in (0, 1]'),
    ('cell_charge_voltage_v', _positive, 'a number > 0'),
    ('cell_cutoff_voltage_v', _positive, 'a number > 0'),
    ('charge_current_a', _positive, 'a number > 0'),
    ('termination_current_a', lambda v: v is None or _positive(v), 'null or a number > 0'),
    ('load_current_a', _non_negative, 'a number >= 0'),
    ('load_power_w', _non_negative, 'a number >= 0'),
    ('ambient_temperature_c', lambda v: is_number(v) and -60 <= v <= 100, 'a number in [-60, 100]'),
    ('initial_temperature_c', lambda v: v is None or (is_number(v) and -60 <= v <= 100),
     'null or a number in [-60, 100]'),
    ('cell_heat_capacity_j_per_k', _positive, 'a number > 0'),
    ('cell_heat_transfer_w_per_k', _positive, 'a number > 0'),
    ('arrhenius_temperature_k', _non_negative, 'a number >= 0'),
    ('reference_temperature_c', lambda v: is_number(v) and -60 <= v <= 100, 'a number in [-60, 100]'),
    ('cell_max_discharge_current_a', _positive, 'a number > 0'),
    ('cell_max_charge_current_a', _positive, 'a number > 0'),
    ('protection_temperature_c', lambda v: is_number(v) and 0 < v <= 150, 'a number in (0, 150]'),
    ('overheat_temperature_c', is_number, 'a number'),
    ('cold_temperature_c', is_number, 'a number'),
    ('capacity_fade_per_cycle', lambda v: is_number(v) and 0 <= v < 0.01, 'a number in [0, 0.01)'),
    ('initial_cycle_count', _non_negative, 'a number >= 0'),
    ('drive_power_w_per_mps', lambda v: is_number(v) and 0 <= v <= MAX_MOTION_POWER_COEFFICIENT,
     'a number in [0, %g] W/(m/s)' % MAX_MOTION_POWER_COEFFICIENT),
    ('turn_power_w_per_radps', lambda v: is_number(v) and 0 <= v <= MAX_MOTION_POWER_COEFFICIENT,
     'a number in [0, %g] W/(rad/s)' % MAX_MOTION_POWER_COEFFICIENT),
    ('cmd_vel_timeout_s', _positive, 'a number > 0'),
    ('voltage_noise_v', lambda v: is_number(v) and 0 <= v <= MAX_VOLTAGE_NOISE_V,
     'a number in [0, %g] V' % MAX_VOLTAGE_NOISE_V),
    ('current_noise_a', lambda v: is_number(v) and 0 <= v <= MAX_CURRENT_NOISE_A,
     'a number in [0, %g] A' % MAX_CURRENT_NOISE_A),
    ('location', lambda v: isinstance(v, str), 'a string'),
    ('serial_number', lambda v: isinstance(v, str), 'a string'),
    ('source', lambda v: isinstance(v, str), 'a string'),
    ('chemistry', lambda v: v in CHEMISTRIES, 'one of %s' % ', '.join(CHEMISTRIES)),
)


def _fail(name, value, allowed):
    raise ParameterError('parameter %s = %r is invalid: must be %s' % (name, value, allowed))


def validate(params):
    """Raise ParameterError naming the first invalid parameter of ``params``."""
    for name, check, allowed in _RULES:
        if not check(getattr(params, name)):
            _fail(name, getattr(params, name), allowed)
    _validate_ocv_table(params)
    _validate_charge_branch(params)
    _validate_resistance_tables(params)
    if params.cell_cutoff_voltage_v >= params.cell_charge_voltage_v:
        _fail('cell_cutoff_voltage_v', params.cell_cutoff_voltage_v,
              'below cell_charge_voltage_v (%g V)' % params.cell_charge_voltage_v)
    if params.cold_temperature_c >= params.overheat_temperature_c:
        _fail('cold_temperature_c', params.cold_temperature_c,
              'below overheat_temperature_c (%g degC)' % params.overheat_temperature_c)
    if params.pack_termination_current_a >= params.charge_current_a:
        if params.termination_current_a is None:   # the C/20 default: the charge current is what is too low
            _fail('charge_current_a', params.charge_current_a,
                  'above the termination current (C/20 = %.3g A; set termination_current_a for another)'
                  % params.pack_termination_current_a)
        _fail('termination_current_a', params.termination_current_a,
              'below charge_current_a (%g A)' % params.charge_current_a)
    if params.overheat_temperature_c > params.protection_temperature_c:
        _fail('overheat_temperature_c', params.overheat_temperature_c,
              'at most protection_temperature_c (%g degC)' % params.protection_temperature_c)
    _validate_currents(params)
    _validate_pack(params)
    _validate_gauge(params)
    _validate_conventions(params)


GROUP_KEYS = ('capacity_factor', 'resistance_factor', 'initial_soc_offset')
BALANCING_KEYS = ('current_a', 'start_voltage_v', 'threshold_v')
GAUGE_KEYS = ('model', 'current_offset_a', 'current_gain_error', 'capacity_error', 'initial_error',
              'deadband_a', 'recalibrate_at_full', 'recalibrate_at_empty')
#: a learning gauge's keys besides the counter's (core/gauge.py's LEARNING_DEFAULTS), each with its rule
LEARNING_GAUGE_KEYS = {
    'relax_current_a': ('a current in (0, 100] A', lambda v: is_number(v) and 0.0 < v <= 100.0),
    'relax_time_s': ('a number of seconds in (0, 86400]', lambda v: is_number(v) and 0.0 < v <= 86400.0),
    'relax_dvdt_v_per_s': ('a voltage change in (0, 0.01] V/s per cell', lambda v: is_number(v) and 0.0 < v <= 0.01),
    'rest_update_period_s': ('a number of seconds in (0, 86400]', lambda v: is_number(v) and 0.0 < v <= 86400.0),
    'gauge_ocv': ('mean, discharge, charge, or a list of cell voltages on ocv_soc',
                  lambda v: v in GAUGE_OCV_TABLES or (isinstance(v, (list, tuple)) and all(map(is_number, v)))),
    'learn_capacity': ('true or false', lambda v: isinstance(v, bool)),
    'learn_min_passed': ('a fraction of the design capacity in (0, 1]', lambda v: is_number(v) and 0.0 < v <= 1.0),
    'learn_first_min_passed': ('a fraction of the design capacity in (0, 1]',
                               lambda v: is_number(v) and 0.0 < v <= 1.0),
    'learn_temperature_min_c': ('a temperature in [-40, 80] degC', lambda v: is_number(v) and -40.0 <= v <= 80.0),
    'learn_temperature_max_c': ('a temperature in [-40, 80] degC', lambda v: is_number(v) and -40.0 <= v <= 80.0),
    'learn_at_end_of_charge': ('true or false', lambda v: isinstance(v, bool)),
    'capacity_update_limit': ('a fraction in (0, 0.5]', lambda v: is_number(v) and 0.0 < v <= 0.5),
    'taper_current_a': ('a current in (0, 100] A', lambda v: is_number(v) and 0.0 < v <= 100.0),
    'taper_current_factor': ('a factor of the termination current in (0, 10]',
                             lambda v: is_number(v) and 0.0 < v <= 10.0),
    'taper_current_min_factor': ('a factor of the termination current in [0, 10]',
                                 lambda v: is_number(v) and 0.0 <= v <= 10.0),
    'taper_window_s': ('a number of seconds in (0, 3600]', lambda v: is_number(v) and 0.0 < v <= 3600.0),
    'taper_windows': ('a whole number in [1, 100]', lambda v: _is_count(v) and v <= 100),
    'taper_voltage_fraction': ('a fraction in (0, 0.5]', lambda v: is_number(v) and 0.0 < v <= 0.5),
    'end_of_charge_min_soc': ('a fraction in [0, 1]', lambda v: is_number(v) and 0.0 <= v <= 1.0),
    'lock_zero': ('true or false', lambda v: isinstance(v, bool)),
    'load_average_s': ('a number of seconds in (0, 3600]', lambda v: is_number(v) and 0.0 < v <= 3600.0),
}
#: gauge_ocv by name: the model's mean of its charge and discharge branches (the default), or one of them
GAUGE_OCV_TABLES = ('mean', 'discharge', 'charge')
#: gauge presets are config/presets/gauge_<name>.yaml: a gauge section that combines with any pack
GAUGE_PRESET_PREFIX = 'gauge_'
#: the spreads are drawn from a normal law clipped to +-SPREAD_SIGMAS: below 1 / SPREAD_SIGMAS every drawn
#: factor, 1 + spread x draw, stays > 0
SPREAD_SIGMAS = 3.0
MAX_SPREAD = 1.0 / SPREAD_SIGMAS
GAUGE_MODELS = ('ideal', 'coulomb_counter', 'learning')
#: conventions: each key with its default and the values allowed
CONVENTION_KEYS = {'invert_current_sign': (False, (False, True)), 'percentage_scale': (1, (1, 100))}


def _validate_pack(params):
    """The groups of a pack of differing cells, and its balancing."""
    for name in ('capacity_spread', 'resistance_spread'):
        value = getattr(params, name)
        if not (is_number(value) and 0.0 <= value < MAX_SPREAD):
            _fail(name, value, 'a relative standard deviation in [0, 1/%g) (its draws reach %g sigma: a larger '
                  'one can draw a factor <= 0)' % (SPREAD_SIGMAS, SPREAD_SIGMAS))
    if not (isinstance(params.spread_seed, int) and not isinstance(params.spread_seed, bool)):
        _fail('spread_seed', params.spread_seed, 'a whole number')
    if not isinstance(params.groups, (tuple, list)):
        _fail('groups', params.groups, 'a list of {%s}, one per series group' % ', '.join(GROUP_KEYS))
    if params.groups:
        if len(params.groups) != params.cells_series:
            _fail('groups', '%d groups' % len(params.groups), 'one per series group: cells_series = %d'
                  % params.cells_series)
        for index, group in enumerate(params.groups):
            if not isinstance(group, dict) or set(group) - set(GROUP_KEYS):
                _fail('groups[%d]' % index, group, 'a mapping of %s' % ', '.join(GROUP_KEYS))
            for key in ('capacity_factor', 'resistance_factor'):
                if key in group and not (is_number(group[key]) and 0.0 < group[key] <= 10.0):
                    _fail('groups[%d].%s' % (index, key), group[key], 'a factor in (0, 10]')
            offset = group.get('initial_soc_offset', 0.0)
            if not (is_number(offset) and -1.0 < offset < 1.0):
                _fail('groups[%d].initial_soc_offset' % index, offset, 'a state of charge offset in (-1, 1)')
    if params.balancing is not None:
        balancing = params.balancing
        if not isinstance(balancing, dict) or set(balancing) != set(BALANCING_KEYS):
            _fail('balancing', balancing, 'a mapping of %s' % ', '.join(BALANCING_KEYS))
        if not (is_number(balancing['current_a']) and 0.0 < balancing['current_a'] <= params.charge_current_a):
            _fail('balancing.current_a', balancing['current_a'],
                  'a bleed current in (0, charge_current_a = %g A]' % params.charge_current_a)
        if not (is_number(balancing['start_voltage_v'])
                and params.cell_cutoff_voltage_v < balancing['start_voltage_v'] <= params.cell_charge_voltage_v):
            _fail('balancing.start_voltage_v', balancing['start_voltage_v'], 'a cell voltage in (%g, %g] V'
                  % (params.cell_cutoff_voltage_v, params.cell_charge_voltage_v))
        if not (is_number(balancing['threshold_v']) and 0.0 <= balancing['threshold_v'] <= 1.0):
            _fail('balancing.threshold_v', balancing['threshold_v'], 'a voltage difference in [0, 1] V')
    if not (is_number(params.imbalance_warn_v) and params.imbalance_warn_v > 0.0):
        _fail('imbalance_warn_v', params.imbalance_warn_v, 'a number > 0 V')


def _validate_gauge(params):
    gauge = params.gauge
    if gauge is None:
        return
    learning = isinstance(gauge, dict) and gauge.get('model') == 'learning'
    keys = set(GAUGE_KEYS) | (set(LEARNING_GAUGE_KEYS) if learning else set())
    if not isinstance(gauge, dict) or set(gauge) - keys or gauge.get('model') not in GAUGE_MODELS:
        unknown = sorted(set(gauge) - keys) if isinstance(gauge, dict) else []
        _fail('gauge', gauge, 'a mapping with model (%s) and %s%s%s' % (
            ' or '.join(GAUGE_MODELS), ', '.join(GAUGE_KEYS[1:]),
            '; a learning gauge also ' + ', '.join(LEARNING_GAUGE_KEYS),
            ' (unknown: %s)' % ', '.join(map(str, unknown)) if unknown else ''))
    for key, (allowed, check) in LEARNING_GAUGE_KEYS.items():
        if key in gauge and not check(gauge[key]):
            _fail('gauge.%s' % key, gauge[key], allowed)
    if learning:
        if isinstance(gauge.get('gauge_ocv'), (list, tuple)):
            table = list(gauge['gauge_ocv'])
            if len(table) != len(params.ocv_soc) or any(b <= a for a, b in zip(table, table[1:])):
                _fail('gauge.gauge_ocv', gauge['gauge_ocv'], 'a list of %d increasing cell voltages (one per '
                      'ocv_soc point)' % len(params.ocv_soc))
        low = gauge.get('learn_temperature_min_c', 10.0)
        if gauge.get('learn_temperature_max_c', 40.0) <= low:
            _fail('gauge.learn_temperature_max_c', gauge.get('learn_temperature_max_c', 40.0),
                  'above learn_temperature_min_c (%g degC)' % low)
    for key, low, high in (('current_offset_a', -100.0, 100.0), ('current_gain_error', -0.5, 0.5),
                           ('capacity_error', -0.5, 0.5), ('initial_error', -100.0, 100.0),
                           ('deadband_a', 0.0, 100.0)):
        if key in gauge and not (is_number(gauge[key]) and low <= gauge[key] <= high):
            _fail('gauge.%s' % key, gauge[key], 'a number in [%g, %g]' % (low, high))
    for key in ('recalibrate_at_full', 'recalibrate_at_empty'):
        if key in gauge and not isinstance(gauge[key], bool):
            _fail('gauge.%s' % key, gauge[key], 'true or false')
    if gauge['model'] == 'ideal' and set(gauge) != {'model'}:
        _fail('gauge', gauge, 'only {model: ideal} for an ideal gauge (its errors belong to coulomb_counter)')


def _validate_conventions(params):
    if not isinstance(params.charger_holds_full, bool):
        _fail('charger_holds_full', params.charger_holds_full, 'true or false')
    conventions = params.conventions
    if conventions is None:
        return
    if not isinstance(conventions, dict) or set(conventions) - set(CONVENTION_KEYS):
        _fail('conventions', conventions, 'a mapping of %s' % ', '.join(CONVENTION_KEYS))
    for key, (_, allowed) in CONVENTION_KEYS.items():
        value = conventions.get(key, CONVENTION_KEYS[key][0])
        if not any(value == a and type(value) is type(a) for a in allowed) \
                and not (key == 'percentage_scale' and isinstance(value, float) and value in allowed):
            _fail('conventions.%s' % key, value, ' or '.join(str(a).lower() for a in allowed))


def _validate_currents(params):
    """The configured loads and charger stay within the cells' datasheet currents."""
    max_charge_a = params.cell_max_charge_current_a * params.cells_parallel
    if params.charge_current_a > max_charge_a:
        _fail('charge_current_a', params.charge_current_a,
              'at most %g A (cell_max_charge_current_a x cells_parallel)' % max_charge_a)
    max_load_a = params.cell_max_discharge_current_a * params.cells_parallel
    if params.load_current_a > max_load_a:
        _fail('load_current_a', params.load_current_a,
              'at most %g A (cell_max_discharge_current_a x cells_parallel)' % max_load_a)
    # The base load must still be deliverable at the cut-off voltage.
    cut_off_v = params.cell_cutoff_voltage_v * params.cells_series
    max_power_w = (max_load_a - params.load_current_a) * cut_off_v
    if params.load_power_w > max_power_w:
        _fail('load_power_w', params.load_power_w,
              'at most %g W (what the pack delivers at %g V beside load_current_a within '
              'cell_max_discharge_current_a)' % (max_power_w, cut_off_v))


def load_power_error(params, field, power_w, total_w, others):
    """Why a load of ``power_w`` W (the request's ``field``) is beyond the pack, or None.

    ``total_w`` is the power it would make with ``others`` (what they are, for the message).
    set_load and the prediction use the same rule: at most what the pack can ever deliver.
    """
    limit_w = params.max_discharge_power_w
    if not 0.0 <= power_w <= limit_w:   # also NaN
        return ('%s = %r is invalid: must be a number in [0, %g] W (the most the pack can deliver)'
                % (field, power_w, limit_w))
    if not total_w <= limit_w:
        return ('%s = %g W is invalid: %s would total %g W, beyond the %g W the pack can deliver'
                % (field, power_w, others, total_w, limit_w))
    return None


#: the charge voltage may lie this far above the OCV at SOC 1 (the full state's OCV, the charge's end less the
#: drop at the termination current), V
CHARGE_VOLTAGE_ABOVE_FULL_V = 0.05


def _validate_ocv_table(params):
    soc, volts = params.ocv_soc, params.ocv_voltage_v
    for name, table in (('ocv_soc', soc), ('ocv_voltage_v', volts)):
        if not isinstance(table, (tuple, list)) or len(table) < 2 \
                or not all(is_number(x) for x in table):
            _fail(name, table, 'a list of at least 2 numbers')
    if len(soc) != len(volts):
        _fail('ocv_voltage_v', volts, 'as many entries as ocv_soc (%d)' % len(soc))
    if soc[0] != 0 or soc[-1] != 1 or any(b <= a for a, b in zip(soc, soc[1:])):
        _fail('ocv_soc', soc, 'strictly increasing from 0 to 1')
    if volts[0] <= 0 or any(b <= a for a, b in zip(volts, volts[1:])):
        _fail('ocv_voltage_v', volts, 'positive and strictly increasing')
    # SOC 1 is the state the CC-CV charge ends in (at the termination current): its OCV lies below the
    # charge voltage by the drop at that current, and the charge ends there at the latest.
    if not volts[0] < params.cell_charge_voltage_v <= volts[-1] + CHARGE_VOLTAGE_ABOVE_FULL_V:
        _fail('cell_charge_voltage_v', params.cell_charge_voltage_v,
              'above the OCV table\'s start and at most %g V above its top (%g..%g V)'
              % (CHARGE_VOLTAGE_ABOVE_FULL_V, volts[0], volts[-1] + CHARGE_VOLTAGE_ABOVE_FULL_V))
    if not volts[0] <= params.cell_cutoff_voltage_v:
        _fail('cell_cutoff_voltage_v', params.cell_cutoff_voltage_v,
              'at or above the OCV table start (%g V)' % volts[0])


def _validate_charge_branch(params):
    volts = params.ocv_charge_voltage_v
    if not isinstance(volts, (tuple, list)) or not all(is_number(x) for x in volts):
        _fail('ocv_charge_voltage_v', volts, 'a list of numbers (empty: no charge branch)')
    if volts and len(volts) != len(params.ocv_soc):
        _fail('ocv_charge_voltage_v', volts, 'empty or as many entries as ocv_soc (%d)' % len(params.ocv_soc))
    if any(b <= a for a, b in zip(volts, volts[1:])):
        _fail('ocv_charge_voltage_v', volts, 'strictly increasing')
    if any(c < d for c, d in zip(volts, params.ocv_voltage_v)):
        _fail('ocv_charge_voltage_v', volts, 'at or above ocv_voltage_v (the discharge branch) at every point')


def _validate_resistance_tables(params):
    grid = params.resistance_soc
    if not isinstance(grid, (tuple, list)) or not all(is_number(x) for x in grid):
        _fail('resistance_soc', grid, 'a list of numbers (empty: resistances independent of SOC)')
    if grid and (len(grid) < 2 or grid[0] != 0 or grid[-1] != 1 or any(b <= a for a, b in zip(grid, grid[1:]))):
        _fail('resistance_soc', grid, 'empty or strictly increasing from 0 to 1')
    for name in ('r0_soc_factor', 'r1_soc_factor', 'r_fast_soc_factor'):
        table = getattr(params, name)
        if not isinstance(table, (tuple, list)) or not all(_positive(x) for x in table):
            _fail(name, table, 'a list of numbers > 0 (empty: 1 at every SOC)')
        if table and len(table) != len(grid):
            _fail(name, table, 'empty or as many entries as resistance_soc (%d)' % len(grid))


PARAMETER_NAMES = tuple(f.name for f in fields(BatteryParameters))
_TABLES = ('ocv_soc', 'ocv_voltage_v', 'ocv_charge_voltage_v', 'resistance_soc', 'r0_soc_factor',
           'r1_soc_factor', 'r_fast_soc_factor')
_WHOLE_NUMBERS = ('cells_series', 'cells_parallel', 'spread_seed')
_NUMBERS = tuple(f.name for f in fields(BatteryParameters) if f.type is float)   # numeric text read as numbers


def from_mapping(values, base=None, origin='parameters'):
    """Build parameters from a mapping (YAML, ROS params) over ``base``.

    Unknown keys and bad values raise ParameterError naming ``origin`` and the key.
    """
    if not isinstance(values, dict):
        raise ParameterError('%s: expected a mapping of parameter names, got %s' % (origin, _what_it_is(values)))
    not_names = [key for key in values if not isinstance(key, str)]
    if not_names:
        raise ParameterError('%s: parameter names must be text, got %r' % (origin, not_names[0]))
    unknown = sorted(set(values) - set(PARAMETER_NAMES) - {'preset'})
    if unknown:
        raise ParameterError('%s: unknown parameter %s (known: %s)'
                             % (origin, unknown[0], ', '.join(PARAMETER_NAMES)))
    if base is None:
        try:
            base = preset(values['preset']) if 'preset' in values else BatteryParameters()
        except ParameterError as error:
            raise ParameterError('%s: %s' % (origin, error)) from None
    changes = {}
    tables = chemistry_tables(values.get('chemistry'))
    if tables and values.get('chemistry') != base.chemistry and not set(tables) & set(values):
        changes.update(tables)   # the chemistry's OCV and voltage limits, unless the config gives its own
        changes.update((key, value) for key, value in LIMITS[values['chemistry']].items() if key not in values)
    if ('ocv_soc' in values or 'ocv_voltage_v' in values) and 'ocv_charge_voltage_v' not in values:
        changes['ocv_charge_voltage_v'] = ()   # a new OCV table without a charge branch: one curve, as before
    for key, value in values.items():
        if key == 'preset':
            continue
        if key in _TABLES and isinstance(value, list):
            value = tuple(number_from_text(v) for v in value)
        elif key == 'groups' and isinstance(value, list):
            if not value:   # not a lumped pack said another way: a list that lost its groups
                raise ParameterError('%s: parameter groups = [] is invalid: must be a list of {%s}, one per '
                                     'series group (leave groups out for a lumped pack)'
                                     % (origin, ', '.join(GROUP_KEYS)))
            value = tuple(value)
        elif key == 'gauge':
            try:
                value = merged_gauge(value, origin)
            except ParameterError as error:
                raise ParameterError('%s: %s' % (origin, error)) from None
        elif key in _NUMBERS:
            value = number_from_text(value)
        if key not in _WHOLE_NUMBERS and isinstance(value, int) and not isinstance(value, bool):
            value = float(value)
        changes[key] = value
    try:
        return replace(base, **changes)
    except ParameterError as error:
        raise ParameterError('%s: %s' % (origin, error)) from None


def _what_it_is(values, longest=40):
    """A value in an error line: short ones as they are, long ones (a file that is not a config) by their kind
    only, never their content."""
    text = repr(values)
    if len(text) <= longest and not isinstance(values, str):
        return text
    if isinstance(values, str):
        return 'text of %d characters (is it a battery config?)' % len(values)
    return 'a %s of %d items' % (type(values).__name__, len(values)) if hasattr(values, '__len__') else \
        'a %s' % type(values).__name__


def load_yaml(path):
    """Load parameters from a YAML file: a ``preset`` (default DEFAULT_PRESET) plus overrides.

    An empty file is refused: it more likely lost its content than meant the default.
    """
    path = Path(path)
    try:
        text = path.read_text(encoding='utf-8')
    except OSError as error:
        raise ParameterError('cannot read battery config %s: %s' % (path, error.strerror)) from None
    except UnicodeDecodeError as error:
        raise ParameterError('battery config %s is not UTF-8 text (byte %d)' % (path, error.start)) from None
    try:
        values = yaml.safe_load(text)
    except yaml.YAMLError as error:   # its problem and where, not the file's text (config:=/etc/passwd)
        mark = getattr(error, 'problem_mark', None)
        where = ' (line %d, column %d)' % (mark.line + 1, mark.column + 1) if mark is not None else ''
        raise ParameterError('%s is not valid YAML%s: %s' % (
            path, where, getattr(error, 'problem', None) or type(error).__name__)) from None
    if values is None:
        raise ParameterError('battery config %s is empty: name a preset (e.g. "preset: %s") and any overrides'
                             % (path, DEFAULT_PRESET))
    if isinstance(values, dict) and 'preset' not in values:
        values = dict(values, preset=DEFAULT_PRESET)
    return from_mapping(values, origin=str(path))


def preset_directory(module_path=__file__):
    """The folder of preset YAML files, in the source/devel tree or the install space.

    ``module_path`` is where this module lives (a parameter so tests can try layouts).
    """
    here = Path(module_path).resolve()
    candidates = [here.parents[3] / 'config' / 'presets']
    if len(here.parents) > 5:  # <prefix>/lib/python3/dist-packages/battery_simulator/core/
        candidates.append(here.parents[5] / 'share' / 'battery_simulator' / 'config' / 'presets')
    for candidate in candidates:
        if candidate.is_dir():
            return candidate
    raise ParameterError('battery presets not found in %s' % ', '.join(map(str, candidates)))


def default_config_path():
    """The package's own config/battery.yaml."""
    return preset_directory().parent / 'battery.yaml'


def preset_names():
    """Names of the shipped battery presets (the gauge presets, gauge_*.yaml, are gauge_preset_names())."""
    return sorted(p.stem for p in preset_directory().glob('*.yaml') if not p.stem.startswith(GAUGE_PRESET_PREFIX))


def gauge_preset_names():
    """Names of the shipped gauge presets (config/presets/gauge_<name>.yaml): impedance_track, modelgauge."""
    return sorted(p.stem[len(GAUGE_PRESET_PREFIX):] for p in preset_directory().glob(GAUGE_PRESET_PREFIX + '*.yaml'))


def gauge_preset(name):
    """The gauge section of the shipped gauge preset ``name`` (a dict; ParameterError naming the known ones)."""
    if not isinstance(name, str) or name not in gauge_preset_names():
        raise ParameterError('gauge preset = %r is invalid: must be one of %s'
                             % (name, ', '.join(gauge_preset_names())))
    return gauge_section(preset_directory() / (GAUGE_PRESET_PREFIX + name + '.yaml'))


def gauge_section(path):
    """The ``gauge`` mapping of a YAML file (a gauge preset, or any battery config), its own ``preset``
    resolved; ParameterError naming the file."""
    path = Path(path)
    try:
        values = yaml.safe_load(path.read_text(encoding='utf-8'))
    except OSError as error:
        raise ParameterError('cannot read gauge config %s: %s' % (path, error.strerror)) from None
    except (UnicodeDecodeError, yaml.YAMLError) as error:
        raise ParameterError('gauge config %s is not valid YAML: %s' % (path, ' '.join(str(error).split()))) from None
    if not isinstance(values, dict) or not isinstance(values.get('gauge'), dict):
        raise ParameterError('gauge config %s has no gauge section (gauge: {model: learning, ...})' % path)
    return merged_gauge(values['gauge'], str(path))


def merged_gauge(gauge, origin='parameters'):
    """A gauge mapping with its ``preset`` (a gauge preset's name) resolved: the preset's keys, then the
    mapping's own over them. Any other value is returned as it is (the validation names what is wrong)."""
    if not isinstance(gauge, dict) or 'preset' not in gauge:
        return gauge
    base = gauge_preset(gauge['preset'])
    merged = dict(base)
    merged.update({key: value for key, value in gauge.items() if key != 'preset'})
    return merged


def with_gauge_config(params, path):
    """``params`` with the gauge of the YAML file ``path`` (a gauge preset such as
    config/presets/gauge_impedance_track.yaml, or any config with a gauge section) in place of its own:
    how a gauge combines with any pack (the nodes' ``gauge_config``). Empty path: ``params`` as they are."""
    if not path:
        return params
    gauge = gauge_section(path)   # its errors name the file
    try:
        return replace(params, gauge=gauge)
    except ParameterError as error:
        raise ParameterError('%s: %s' % (path, error)) from None


def preset(name):
    """The shipped preset called ``name``."""
    if not isinstance(name, str) or name not in preset_names():
        raise ParameterError('parameter preset = %r is invalid: must be one of %s' % (name, ', '.join(preset_names())))
    path = preset_directory() / (name + '.yaml')
    values = yaml.safe_load(path.read_text(encoding='utf-8'))
    if 'preset' in values:  # a pack built on a cell preset
        base = preset(values.pop('preset'))
        return from_mapping(values, base=base, origin=str(path))
    return from_mapping(values, base=BatteryParameters(), origin=str(path))


DEFAULT_PRESET = 'lg_hg2_3s1p'
