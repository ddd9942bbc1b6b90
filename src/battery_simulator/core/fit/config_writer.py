"""The fitted battery as a config YAML (no ROS): the chemistry preset plus the fitted values, each
commented with where it came from and its uncertainty, checked by core/parameter_rules.py before it is written."""
import contextlib
import os

import yaml

from battery_simulator.core.config_files import from_mapping
from battery_simulator.core.fit import FitError
from battery_simulator.core.parameter_rules import ParameterError

#: the keys written, in this order (the ones the fit sets)
ORDER = ('name', 'source', 'cells_series', 'cells_parallel', 'cell_capacity_ah', 'ocv_soc', 'ocv_voltage_v',
         'ocv_charge_voltage_v', 'r0_ohm', 'r1_ohm', 'tau1_s', 'r_fast_ohm', 'tau_fast_s', 'surface_soc_lag_s',
         'tau_surface_s', 'resistance_soc',
         'r0_soc_factor', 'r1_soc_factor', 'r_fast_soc_factor', 'coulombic_efficiency', 'cell_charge_voltage_v',
         'cell_cutoff_voltage_v',
         'charge_current_a', 'termination_current_a', 'load_current_a', 'load_power_w', 'drive_power_w_per_mps',
         'turn_power_w_per_radps', 'ambient_temperature_c', 'initial_temperature_c', 'cell_heat_capacity_j_per_k',
         'cell_heat_transfer_w_per_k', 'cell_max_discharge_current_a', 'cell_max_charge_current_a',
         'profile_current_timing')


#: the first line of every config battery_fit writes (only such a file may be written over)
WRITTEN_BY = '# Battery config written by battery_fit'


def config_text(result, command=''):
    """The YAML text of ``result`` (a FitResult); FitError if it would not load."""
    params = result.params
    base = result.params   # every written key's value comes from the fitted parameters
    lines = [WRITTEN_BY + '%s' % (': ' + command if command else ''),
             '# from: %s' % ', '.join(log.name for log in result.logs),
             '# Values the logs could not identify are the %s preset\'s (see the report).' % result.chemistry,
             'preset: %s' % result.chemistry]
    values = {}
    for name in ORDER:
        value = getattr(base, name)
        default = getattr(from_mapping({'preset': result.chemistry}), name)
        if value == default and name not in result.fitted and name not in ('name', 'source'):
            continue
        values[name] = list(value) if isinstance(value, tuple) else value
        comment = _comment(result, name)
        text = yaml.safe_dump({name: values[name]}, default_flow_style=True, width=100000).strip()
        if text.startswith('{') and text.endswith('}'):
            text = text[1:-1]
        lines.append(text + ('  # ' + comment if comment else ''))
    text = '\n'.join(lines) + '\n'
    try:
        loaded = from_mapping(yaml.safe_load(text), origin='the fitted config')
    except ParameterError as error:
        raise FitError('the fitted config would not load: %s' % error) from None
    if loaded.cells_series != params.cells_series or loaded.design_capacity_ah != params.design_capacity_ah:
        raise FitError('the fitted config does not read back as fitted')
    return text


def _comment(result, name):
    fitted = result.fitted.get(name)
    if fitted is None:
        why = result.kept.get(name)
        return 'kept: %s' % why if why else ''
    text = fitted.source
    if fitted.uncertainty is not None and fitted.uncertainty == fitted.uncertainty:   # not NaN
        text += ' (+- %.2g, 1 sigma)' % fitted.uncertainty
    if isinstance(fitted.value, str):
        text = fitted.value + ': ' + text
    return text


def write_config(path, text):
    """All or nothing: written to a new file of its own beside ``path`` (never a user's OUT.yaml.part) and
    renamed, so a failure leaves an older file as it was."""
    import tempfile
    partial = None
    try:
        handle, partial = tempfile.mkstemp(prefix='.%s.' % os.path.basename(path), suffix='.part',
                                           dir=os.path.dirname(os.path.abspath(path)))
        with os.fdopen(handle, 'w', encoding='utf-8') as stream:
            stream.write(text)
        os.chmod(partial, 0o644)
        os.replace(partial, path)
        partial = None
    except OSError as error:
        raise FitError('cannot write %s: %s' % (path, error.strerror)) from None
    finally:
        if partial is not None:
            with contextlib.suppress(OSError):
                os.remove(partial)
