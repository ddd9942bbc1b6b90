"""Each validation rule: its exact one-line message and both sides of its boundary."""
from dataclasses import replace

import pytest

from battery_simulator.core import config_files
from battery_simulator.core.battery_parameters import PARAMETER_NAMES, BatteryParameters
from battery_simulator.core.config_files import from_mapping, load_yaml, preset, preset_directory, preset_names
from battery_simulator.core.parameter_rules import ParameterError

NAN = float('nan')

# (parameter, first value past the boundary, what the message says is allowed)
REJECTED = [
    ('name', '', 'a non-empty string'),
    ('cells_series', 0, 'a whole number in [1, 200]'),
    ('cells_series', 201, 'a whole number in [1, 200]'),
    ('cells_series', 2.0, 'a whole number in [1, 200]'),
    ('cells_parallel', True, 'a whole number in [1, 200]'),
    ('cells_parallel', 201, 'a whole number in [1, 200]'),
    ('cell_capacity_ah', 0.0, 'a number > 0'),
    ('r0_ohm', 0.0, 'a number > 0'),
    ('r1_ohm', -1e-9, 'a number >= 0'),
    ('tau1_s', 0.0, 'a number > 0'),
    ('coulombic_efficiency', 0.0, 'a number in (0, 1]'),
    ('coulombic_efficiency', 1.0001, 'a number in (0, 1]'),
    ('cell_charge_voltage_v', 0.0, 'a number > 0'),
    ('cell_cutoff_voltage_v', 0.0, 'a number > 0'),
    ('charge_current_a', 0.0, 'a number > 0'),
    ('termination_current_a', 0.0, 'null or a number > 0'),
    ('load_current_a', -0.001, 'a number >= 0'),
    ('load_power_w', -0.001, 'a number >= 0'),
    ('ambient_temperature_c', -60.5, 'a number in [-60, 100]'),
    ('ambient_temperature_c', 100.5, 'a number in [-60, 100]'),
    ('initial_temperature_c', -60.5, 'null or a number in [-60, 100]'),
    ('initial_temperature_c', 100.5, 'null or a number in [-60, 100]'),
    ('initial_temperature_c', 'warm', 'null or a number in [-60, 100]'),
    ('cell_heat_capacity_j_per_k', 0.0, 'a number > 0'),
    ('cell_heat_transfer_w_per_k', 0.0, 'a number > 0'),
    ('arrhenius_temperature_k', -1.0, 'a number >= 0'),
    ('reference_temperature_c', -60.5, 'a number in [-60, 100]'),
    ('reference_temperature_c', 100.5, 'a number in [-60, 100]'),
    ('cell_max_discharge_current_a', 0.0, 'a number > 0'),
    ('cell_max_charge_current_a', 0.0, 'a number > 0'),
    ('protection_temperature_c', 0.0, 'a number in (0, 150]'),
    ('protection_temperature_c', 150.5, 'a number in (0, 150]'),
    ('overheat_temperature_c', NAN, 'a number'),
    ('cold_temperature_c', 'cold', 'a number'),
    ('capacity_fade_per_cycle', 0.01, 'a number in [0, 0.01)'),
    ('capacity_fade_per_cycle', -1e-6, 'a number in [0, 0.01)'),
    ('initial_cycle_count', -1.0, 'a number >= 0'),
    ('drive_power_w_per_mps', -1.0, 'a number in [0, 10000] W/(m/s)'),
    ('drive_power_w_per_mps', 1e308, 'a number in [0, 10000] W/(m/s)'),   # its power would overflow
    ('turn_power_w_per_radps', -1.0, 'a number in [0, 10000] W/(rad/s)'),
    ('turn_power_w_per_radps', 10000.001, 'a number in [0, 10000] W/(rad/s)'),
    ('cmd_vel_timeout_s', 0.0, 'a number > 0'),
    ('voltage_noise_v', -0.1, 'a number in [0, 1] V'),
    ('voltage_noise_v', 1.0e308, 'a number in [0, 1] V'),   # the first noisy publish overflowed
    ('voltage_noise_v', 1.0e6, 'a number in [0, 1] V'),     # reported negative voltages
    ('current_noise_a', -0.1, 'a number in [0, 5] A'),
    ('current_noise_a', 5.001, 'a number in [0, 5] A'),
    ('location', None, 'a string'),
    ('serial_number', 5, 'a string'),
    ('source', None, 'a string'),
]

# values exactly on a boundary, which are allowed
ACCEPTED = [
    ('cells_series', 200), ('r1_ohm', 0.0), ('coulombic_efficiency', 1.0),
    ('termination_current_a', None), ('load_current_a', 0.0), ('load_power_w', 0.0),
    ('ambient_temperature_c', -60.0), ('ambient_temperature_c', 100.0), ('initial_temperature_c', -60.0),
    ('initial_temperature_c', 100.0), ('arrhenius_temperature_k', 0.0), ('reference_temperature_c', -60.0),
    ('reference_temperature_c', 100.0), ('protection_temperature_c', 150.0), ('capacity_fade_per_cycle', 0.0),
    ('initial_cycle_count', 0.0), ('voltage_noise_v', 0.0), ('voltage_noise_v', 1.0), ('current_noise_a', 5.0),
    ('drive_power_w_per_mps', 10000.0), ('turn_power_w_per_radps', 10000.0), ('location', ''),
    ('overheat_temperature_c', 75.0),          # equal to the protection temperature
    ('charge_current_a', 4.0),                 # cell_max_charge_current_a x 1
    ('load_current_a', 20.0),                  # cell_max_discharge_current_a x 1
    ('cell_cutoff_voltage_v', 2.8),            # the OCV table's start
]


def message(name, value, allowed):
    return 'parameter %s = %r is invalid: must be %s' % (name, value, allowed)


def value_after(changes, name):
    """What parameter ``name`` is once ``changes`` are applied to the defaults."""
    return changes.get(name, getattr(BatteryParameters(), name))


def rejection(**changes):
    with pytest.raises(ParameterError) as error:
        replace(BatteryParameters(), **changes)
    return str(error.value)


@pytest.mark.parametrize('name, value, allowed', REJECTED)
def test_each_rule_names_the_parameter_value_and_what_is_allowed(name, value, allowed):
    assert rejection(**{name: value}) == message(name, value, allowed)


@pytest.mark.parametrize('name, value', ACCEPTED)
def test_values_on_a_boundary_are_allowed(name, value):
    assert getattr(replace(BatteryParameters(), **{name: value}), name) == value


@pytest.mark.parametrize('changes, name, allowed', [
    ({'cell_cutoff_voltage_v': 4.2}, 'cell_cutoff_voltage_v', 'below cell_charge_voltage_v (4.2 V)'),
    ({'cold_temperature_c': 60.0}, 'cold_temperature_c', 'below overheat_temperature_c (60 degC)'),
    ({'termination_current_a': 1.5}, 'termination_current_a', 'below charge_current_a (1.5 A)'),
    # with the C/20 default (0.139 A here) the charge current is what is too low, not a termination 'None'
    ({'charge_current_a': 0.1}, 'charge_current_a',
     'above the termination current (C/20 = 0.139 A; set termination_current_a for another)'),
    ({'overheat_temperature_c': 75.5}, 'overheat_temperature_c', 'at most protection_temperature_c (75 degC)'),
    ({'charge_current_a': 4.001}, 'charge_current_a', 'at most 4 A (cell_max_charge_current_a x cells_parallel)'),
    ({'cells_parallel': 2, 'charge_current_a': 8.5}, 'charge_current_a',
     'at most 8 A (cell_max_charge_current_a x cells_parallel)'),
    ({'cells_parallel': 2, 'load_current_a': 40.5}, 'load_current_a',
     'at most 40 A (cell_max_discharge_current_a x cells_parallel)'),
])
def test_cross_checks_name_the_limit_and_its_figure(changes, name, allowed):
    assert rejection(**changes) == message(name, value_after(changes, name), allowed)


def test_limits_scale_with_the_cells_in_parallel():
    params = replace(BatteryParameters(), cells_parallel=2, charge_current_a=8.0, load_current_a=40.0)
    assert (params.charge_current_a, params.load_current_a) == (8.0, 40.0)
    assert replace(BatteryParameters(), cells_parallel=200, termination_current_a=0.1).cells_parallel == 200


def test_the_power_load_is_limited_to_what_is_left_beside_the_current_load():
    # 2 cells at a 2.5 V cut-off = 5 V; (20 A - 2 A) x 5 V = 90 W
    base = replace(BatteryParameters(), ocv_voltage_v=(2.5, 4.2), cell_cutoff_voltage_v=2.5, cells_series=2,
                   load_current_a=2.0)
    assert replace(base, load_power_w=90.0).load_power_w == 90.0
    with pytest.raises(ParameterError) as error:
        replace(base, load_power_w=90.5)
    assert str(error.value) == message('load_power_w', 90.5, (
        'at most 90 W (what the pack delivers at 5 V beside load_current_a within cell_max_discharge_current_a)'))


OCV = {'ocv_soc': (0.0, 0.5, 1.0), 'ocv_voltage_v': (2.8, 3.6, 4.2)}


@pytest.mark.parametrize('changes, name, allowed', [
    ({'ocv_soc': 'abc'}, 'ocv_soc', 'a list of at least 2 numbers'),
    ({'ocv_soc': (0.0,)}, 'ocv_soc', 'a list of at least 2 numbers'),
    ({'ocv_voltage_v': (2.8, 'x', 4.2)}, 'ocv_voltage_v', 'a list of at least 2 numbers'),
    ({'ocv_voltage_v': (2.8, 4.2)}, 'ocv_voltage_v', 'as many entries as ocv_soc (3)'),
    ({'ocv_soc': (0.1, 0.5, 1.0)}, 'ocv_soc', 'strictly increasing from 0 to 1'),
    ({'ocv_soc': (0.0, 0.5, 0.9)}, 'ocv_soc', 'strictly increasing from 0 to 1'),
    ({'ocv_soc': (0.0, 0.0, 1.0)}, 'ocv_soc', 'strictly increasing from 0 to 1'),
    ({'ocv_voltage_v': (0.0, 3.6, 4.2)}, 'ocv_voltage_v', 'positive and strictly increasing'),
    ({'ocv_voltage_v': (2.8, 2.8, 4.2)}, 'ocv_voltage_v', 'positive and strictly increasing'),
    ({'cell_charge_voltage_v': 4.3}, 'cell_charge_voltage_v', 'above the OCV table\'s start and at most 0.05 V above its top (2.8..4.25 V)'),
    ({'cell_charge_voltage_v': 2.8}, 'cell_charge_voltage_v', 'above the OCV table\'s start and at most 0.05 V above its top (2.8..4.25 V)'),
    ({'cell_cutoff_voltage_v': 2.7}, 'cell_cutoff_voltage_v', 'at or above the OCV table start (2.8 V)'),
])
def test_ocv_table_rules(changes, name, allowed):
    changes = {**OCV, **changes}
    assert rejection(**changes) == message(name, value_after(changes, name), allowed)


def test_an_ocv_table_may_start_below_one_volt():
    params = replace(BatteryParameters(), ocv_voltage_v=(0.5, 4.2))
    assert params.ocv_voltage_v == (0.5, 4.2)


def test_from_mapping_messages_name_the_origin():
    with pytest.raises(ParameterError) as error:
        from_mapping({'load_current_a': -1})
    assert str(error.value) == 'parameters: ' + message('load_current_a', -1.0, 'a number >= 0')
    with pytest.raises(ParameterError) as error:
        from_mapping([1])
    assert str(error.value) == 'parameters: expected a mapping of parameter names, got [1]'
    with pytest.raises(ParameterError) as error:
        from_mapping({1: 2})
    assert str(error.value) == 'parameters: parameter names must be text, got 1'
    with pytest.raises(ParameterError) as error:
        from_mapping({'zzz': 1}, origin='robot.yaml')
    assert str(error.value) == 'robot.yaml: unknown parameter zzz (known: %s)' % ', '.join(PARAMETER_NAMES)
    assert str(error.value).endswith('(known: name, cells_series, cells_parallel, cell_capacity_ah, ocv_soc, '
                                     'ocv_voltage_v, r0_ohm, r1_ohm, tau1_s, r_fast_ohm, tau_fast_s, surface_soc_lag_s, tau_surface_s, '
                                     'resistance_soc, '
                                     'r0_soc_factor, r1_soc_factor, r_fast_soc_factor, r0_charge_factor, '
                                     'r1_charge_factor, r_fast_charge_factor, ocv_charge_voltage_v, hysteresis_ah, '
                                     'coulombic_efficiency, '
                                     'cell_charge_voltage_v, cell_cutoff_voltage_v, charge_current_a, '
                                     'termination_current_a, load_current_a, load_power_w, ambient_temperature_c, '
                                     'initial_temperature_c, cell_heat_capacity_j_per_k, cell_heat_transfer_w_per_k, '
                                     'arrhenius_temperature_k, reference_temperature_c, cell_max_discharge_current_a, '
                                     'cell_max_charge_current_a, protection_temperature_c, overheat_temperature_c, '
                                     'cold_temperature_c, capacity_fade_per_cycle, initial_cycle_count, '
                                     'drive_power_w_per_mps, turn_power_w_per_radps, cmd_vel_timeout_s, '
                                     'voltage_noise_v, current_noise_a, location, serial_number, source, chemistry, '
                                     'profile_current_timing, capacity_spread, '
                                     'resistance_spread, spread_seed, groups, balancing, imbalance_warn_v, gauge, charger_holds_full, conventions)')
    with pytest.raises(ParameterError) as error:
        from_mapping({'preset': 'turbo'})
    assert str(error.value) == "parameters: parameter preset = 'turbo' is invalid: must be one of %s" % (
        ', '.join(preset_names()))


def test_from_mapping_without_a_preset_builds_on_the_defaults():
    assert from_mapping({'load_current_a': 2.0}) == replace(BatteryParameters(), load_current_a=2.0)


def test_from_mapping_converts_yaml_lists_and_whole_numbers_only_where_they_belong():
    params = from_mapping({'ocv_soc': [0, 1], 'ocv_voltage_v': [2.8, 4.2], 'load_current_a': 2, 'cells_series': 2})
    assert params.ocv_soc == (0.0, 1.0) and params.ocv_voltage_v == (2.8, 4.2)
    assert type(params.load_current_a) is float and type(params.cells_series) is int
    with pytest.raises(ParameterError) as error:
        from_mapping({'location': [1, 2]})
    assert str(error.value) == 'parameters: ' + message('location', [1, 2], 'a string')
    with pytest.raises(ParameterError) as error:
        from_mapping({'load_current_a': True})
    assert str(error.value) == 'parameters: ' + message('load_current_a', True, 'a number >= 0')


def test_load_yaml_messages(tmp_path):
    absent = tmp_path / 'absent.yaml'
    with pytest.raises(ParameterError) as error:
        load_yaml(absent)
    assert str(error.value) == 'cannot read battery config %s: No such file or directory' % absent
    binary = tmp_path / 'binary.yaml'
    binary.write_bytes(b'preset: lg_hg2_3s1p\nlocation: "\xff"\n')
    with pytest.raises(ParameterError) as error:
        load_yaml(binary)
    assert str(error.value) == 'battery config %s is not UTF-8 text (byte 31)' % binary
    empty = tmp_path / 'empty.yaml'
    empty.write_text('')
    with pytest.raises(ParameterError) as error:
        load_yaml(empty)
    assert str(error.value) == ('battery config %s is empty: name a preset (e.g. "preset: lg_hg2_3s1p") '
                                'and any overrides' % empty)
    broken = tmp_path / 'broken.yaml'
    broken.write_text('preset: [unclosed\n')
    with pytest.raises(ParameterError) as error:
        load_yaml(broken)
    # the problem and where it is, never the file's text (config:=/etc/passwd printed 200 characters of it)
    assert str(error.value) == "%s is not valid YAML (line 2, column 1): expected ',' or ']', but got " \
        "'<stream end>'" % broken
    assert 'unclosed' not in str(error.value)
    secret = tmp_path / 'passwd'
    secret.write_text('root:x:0:0:root:/root:/bin/bash\n' * 40)
    with pytest.raises(ParameterError) as error:
        load_yaml(secret)
    assert str(secret) in str(error.value) and 'root' not in str(error.value).replace(str(tmp_path), '')


def test_unknown_preset_message_lists_every_preset():
    with pytest.raises(ParameterError) as error:
        preset('turbo')
    assert str(error.value) == "parameter preset = 'turbo' is invalid: must be one of %s" % ', '.join(preset_names())
    assert 'kobuki_4s2p, lg_hg2_3s1p' in str(error.value)


def test_a_bad_shipped_preset_names_its_file(tmp_path, monkeypatch):
    (tmp_path / 'cell.yaml').write_text('name: cell\nload_current_a: -1\n')
    (tmp_path / 'good_cell.yaml').write_text('name: good_cell\n')
    (tmp_path / 'pack.yaml').write_text('preset: good_cell\nname: pack\nload_current_a: -2\n')
    monkeypatch.setattr(config_files, 'preset_directory', lambda: tmp_path)
    with pytest.raises(ParameterError) as error:
        preset('cell')
    assert str(error.value) == '%s: %s' % (tmp_path / 'cell.yaml', message('load_current_a', -1.0, 'a number >= 0'))
    with pytest.raises(ParameterError) as error:
        preset('pack')
    assert str(error.value) == '%s: %s' % (tmp_path / 'pack.yaml', message('load_current_a', -2.0, 'a number >= 0'))


def test_presets_are_found_in_the_source_tree_and_the_install_space(tmp_path):
    source_presets = tmp_path / 'src_ws' / 'config' / 'presets'
    source_presets.mkdir(parents=True)
    assert preset_directory(tmp_path / 'src_ws' / 'src' / 'battery_simulator' / 'core' / 'p.py') == source_presets
    installed = tmp_path / 'prefix' / 'share' / 'battery_simulator' / 'config' / 'presets'
    installed.mkdir(parents=True)
    module = tmp_path / 'prefix' / 'lib' / 'python3' / 'dist-packages' / 'battery_simulator' / 'core' / 'p.py'
    assert preset_directory(module) == installed


def test_missing_presets_list_every_place_looked():
    with pytest.raises(ParameterError) as error:
        preset_directory('/zz/python3/dist-packages/battery_simulator/core/p.py')
    assert str(error.value) == ('battery presets not found in /zz/python3/config/presets, '
                                '/share/battery_simulator/config/presets')
    with pytest.raises(ParameterError) as error:
        preset_directory('/x1/x2/x3/x4/p.py')   # too short for an install space
    assert str(error.value) == 'battery presets not found in /x1/config/presets'
