"""Battery configs, without ROS: parameters from a mapping (YAML, ROS params) over a base, from a YAML
file, from the shipped presets (config/presets/) and gauge presets, and a gauge config over any pack."""
from dataclasses import fields, replace
from pathlib import Path

import yaml

from battery_simulator.core.battery_parameters import PARAMETER_NAMES, BatteryParameters
from battery_simulator.core.lfp_tables import LIMITS, chemistry_tables
from battery_simulator.core.parameter_rules import GROUP_KEYS, ParameterError, number_from_text

#: gauge presets are config/presets/gauge_<name>.yaml: a gauge section that combines with any pack
GAUGE_PRESET_PREFIX = 'gauge_'

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
