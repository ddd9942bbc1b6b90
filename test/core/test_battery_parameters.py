"""Parameter validation, YAML loading and presets."""
from dataclasses import replace

import pytest

from battery_simulator.core.battery_parameters import PARAMETER_NAMES, BatteryParameters
from battery_simulator.core.config_files import default_config_path, load_yaml, preset, preset_names
from battery_simulator.core.parameter_rules import ParameterError

BAD_VALUES = [
    ('cells_series', 0), ('cells_series', 2.5), ('cells_parallel', True), ('cell_capacity_ah', -1.0),
    ('r0_ohm', 0.0), ('r1_ohm', -0.01), ('tau1_s', float('nan')), ('coulombic_efficiency', 1.2),
    ('charge_current_a', 0.0), ('termination_current_a', 5.0), ('load_current_a', -1.0),
    ('load_power_w', 'lots'), ('ambient_temperature_c', 500.0), ('cell_heat_capacity_j_per_k', 0.0),
    ('capacity_fade_per_cycle', 0.5), ('cell_cutoff_voltage_v', 4.3), ('cell_charge_voltage_v', 4.5),
    ('ocv_soc', (0.0, 0.7, 0.5, 1.0)), ('ocv_voltage_v', (3.0, 3.9, 3.8, 4.2)),
    ('cold_temperature_c', 80.0), ('name', ''),
]


@pytest.mark.parametrize('name, value', BAD_VALUES)
def test_invalid_value_names_parameter_value_and_rule(name, value):
    base = preset('lg_hg2_cell')
    if name in ('ocv_soc', 'ocv_voltage_v'):
        base = replace(base, ocv_soc=(0.0, 0.3, 0.6, 1.0), ocv_voltage_v=(2.8, 3.6, 3.9, 4.2), ocv_charge_voltage_v=())
    with pytest.raises(ParameterError) as error:
        replace(base, **{name: value})
    message = str(error.value)
    assert name in message and repr(value) in message and 'must be' in message, message


def test_every_parameter_has_a_unit_or_is_a_count_or_text():
    units = ('_ah', '_v', '_ohm', '_s', '_a', '_w', '_c', '_k', '_j_per_k', '_w_per_k', '_w_per_mps', '_w_per_radps')
    unitless = {'name', 'cells_series', 'cells_parallel', 'ocv_soc', 'coulombic_efficiency',
                'capacity_fade_per_cycle', 'initial_cycle_count', 'location', 'serial_number', 'source',
                'resistance_soc', 'r0_soc_factor', 'r1_soc_factor', 'r_fast_soc_factor', 'r0_charge_factor',
                'r1_charge_factor', 'r_fast_charge_factor',
                # Part 5: relative spreads, a seed, and mappings whose keys carry their units
                'capacity_spread', 'resistance_spread', 'spread_seed', 'groups', 'balancing', 'gauge',
                # Part 7: a switch, and a mapping of a sign and a scale
                'charger_holds_full', 'conventions',
                # Part 8: a name (li-ion or lfp)
                'chemistry',
                # Part 8: when a replayed profile's current flowed (a name)
                'profile_current_timing'}
    for name in PARAMETER_NAMES:
        assert name in unitless or name.endswith(units), name


def test_defaults_are_valid():
    assert BatteryParameters().design_capacity_ah > 0


def test_presets_load_and_carry_their_source():
    names = preset_names()
    assert {'lg_hg2_cell', 'lg_hg2_3s1p', 'kobuki_4s2p', 'lg_hg2_7s4p'} <= set(names)
    for name in names:
        params = preset(name)
        assert params.name == name and params.source, name
    pack = preset('lg_hg2_3s1p')
    assert (pack.cells_series, pack.cells_parallel) == (3, 1)
    assert pack.ocv_voltage_v == preset('lg_hg2_cell').ocv_voltage_v


def test_unknown_preset_lists_the_known_ones():
    with pytest.raises(ParameterError, match='lg_hg2_3s1p'):
        preset('turbo')


def test_yaml_preset_with_overrides(tmp_path):
    path = tmp_path / 'robot.yaml'
    path.write_text('preset: kobuki_4s2p\nload_current_a: 2\nlocation: rear\n')
    params = load_yaml(path)
    assert params.cells_series == 4 and params.load_current_a == 2.0 and params.location == 'rear'


def test_default_config_is_the_default_pack():
    assert load_yaml(default_config_path()).name == 'lg_hg2_3s1p'


@pytest.mark.parametrize('text, expected', [
    ('load_current_a: -3\n', 'load_current_a'),
    ('no_such_thing: 1\n', 'no_such_thing'),
    ('preset: [1, 2]\n', 'preset'),
    ('- just\n- a list\n', 'mapping'),
    ('load_current_a: [unclosed\n', 'not valid YAML'),
])
def test_bad_yaml_names_the_file_and_key(tmp_path, text, expected):
    path = tmp_path / 'bad.yaml'
    path.write_text(text)
    with pytest.raises(ParameterError) as error:
        load_yaml(path)
    assert expected in str(error.value) and str(path) in str(error.value), str(error.value)


def test_missing_yaml_file_is_a_clear_error(tmp_path):
    with pytest.raises(ParameterError, match='cannot read'):
        load_yaml(tmp_path / 'absent.yaml')


@pytest.mark.parametrize('content, expected', [
    (b'', 'is empty: name a preset'),
    (b'# only a comment\n', 'is empty: name a preset'),
    (b'1: 2\npreset: lg_hg2_3s1p\n', 'parameter names must be text, got 1'),
    (b'preset: lg_hg2_3s1p\nlocation: "\xff\xfe"\n', 'is not UTF-8 text'),
    (b'preset: [unclosed\n', 'is not valid YAML'),
    (b'- a\n- list\n', 'expected a mapping'),
])
def test_bad_config_files_give_one_clear_line(tmp_path, content, expected):
    path = tmp_path / 'battery.yaml'
    path.write_bytes(content)
    with pytest.raises(ParameterError) as error:
        load_yaml(path)
    message = str(error.value)
    assert expected in message and str(path) in message and '\n' not in message, message


def test_a_config_without_a_preset_builds_on_the_default_preset(tmp_path):
    path = tmp_path / 'battery.yaml'
    path.write_text('load_current_a: 2.0\n')
    params = load_yaml(path)
    assert params.name == 'lg_hg2_3s1p' and params.cells_series == 3 and params.load_current_a == 2.0


def test_numeric_text_from_roslaunch_is_read_as_a_number():
    ros_parameters = pytest.importorskip('battery_simulator.ros1.startup')
    assert ros_parameters.number_from_text('1e9') == 1e9
    assert ros_parameters.number_from_text(' 22 ') == 22.0
    assert ros_parameters.number_from_text('fast') == 'fast'
    assert ros_parameters.number_from_text(3) == 3


def test_numbers_that_yaml_reads_as_text_are_numbers(tmp_path):
    # PyYAML reads a float without a dot or an exponent sign ("1.0e6", "1e3") as text;
    # launch arguments accept numeric text, so the config file does too.
    path = tmp_path / 'battery.yaml'
    path.write_text('load_power_w: 1.0e1\ncharge_current_a: 2e0\nocv_voltage_v: [2.5e0, 3.6, 4.25]\n'
                    'ocv_soc: [0, 0.5, 1]\n')
    params = load_yaml(path)
    assert (params.load_power_w, params.charge_current_a) == (10.0, 2.0)
    assert params.ocv_voltage_v == (2.5, 3.6, 4.25)
    path.write_text('voltage_noise_v: 1.0e+308\n')
    with pytest.raises(ParameterError, match=r'voltage_noise_v = 1e\+308 is invalid: must be a number in \[0, 1\] V'):
        load_yaml(path)
    path.write_text('load_power_w: 1.0e6x\n')
    with pytest.raises(ParameterError, match="load_power_w = '1.0e6x' is invalid"):
        load_yaml(path)
