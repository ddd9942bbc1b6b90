"""The battery parameters' rules, without ROS: what each value may be, checked together (``validate``),
with the one error every refusal raises (ParameterError) and the number checks the package shares."""
import math

from battery_simulator.core.lfp_tables import CHEMISTRIES

#: battery_replay's profile timings (BatteryParameters.profile_current_timing)
PROFILE_TIMINGS = ('until_next_row', 'since_previous_row')


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
#: the longest surface SOC lag, s: an hour of the current (settled at 1C the surface trails the bulk by the whole
#: capacity; battery_fit searches up to 2000 s). Beyond it a charge from 20 % ended Full at 20 % within 3 s
#: (1e6 s) and the state it saved (a lag of -1.43, or NaN at 1.7e308 s) could not be resumed
MAX_SURFACE_SOC_LAG_S = 3600.0

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
    ('surface_soc_lag_s', lambda v: _non_negative(v) and v <= MAX_SURFACE_SOC_LAG_S,
     'a number in [0, %g] s' % MAX_SURFACE_SOC_LAG_S),
    ('tau_surface_s', _positive, 'a number > 0'),
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
    ('profile_current_timing', lambda v: v in PROFILE_TIMINGS, 'one of %s' % ', '.join(PROFILE_TIMINGS)),
)


def refusal(name, value, reason):
    """The one text of a refused setting or parameter, at start-up or at run time (both front ends, the config):
    ``parameter NAME = VALUE is invalid: REASON`` (a run-time refusal adds where it keeps the old value)."""
    return 'parameter %s = %r is invalid: %s' % (name, value, reason)


def _fail(name, value, allowed):
    raise ParameterError(refusal(name, value, 'must be ' + allowed))


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
        _validate_taper_band(params, gauge)
        low, high = gauge.get('learn_temperature_min_c', 10.0), gauge.get('learn_temperature_max_c', 40.0)
        if high <= low:
            if 'learn_temperature_max_c' not in gauge:   # the value given is the one to name
                _fail('gauge.learn_temperature_min_c', low, 'below learn_temperature_max_c (%g degC)' % high)
            _fail('gauge.learn_temperature_max_c', high, 'above learn_temperature_min_c (%g degC)' % low)
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


def _validate_taper_band(params, gauge):
    """A learning gauge's end of charge needs a current band: its lower bound (taper_current_min_factor x the
    termination current) below its upper (taper_current_a, or taper_current_factor x the termination current)."""
    termination_a = params.pack_termination_current_a
    # the defaults are core/gauge.py's LEARNING_DEFAULTS' (as learn_temperature_*'s above: it imports this module)
    min_factor = gauge.get('taper_current_min_factor', 0.0)
    if 'taper_current_a' in gauge:
        if min_factor * termination_a >= gauge['taper_current_a']:
            _fail('gauge.taper_current_min_factor', min_factor, 'below taper_current_a (%g A) / the termination '
                  'current (%g A): the end of charge\'s band would be empty' % (gauge['taper_current_a'],
                                                                               termination_a))
        return
    factor = gauge.get('taper_current_factor', 1.1)
    if min_factor >= factor:
        _fail('gauge.taper_current_min_factor', min_factor, 'below taper_current_factor (%g): the end of '
              'charge\'s band would be empty' % factor)


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
