"""Runs whose figures were saved from the single-RC model before issue 25
(test/data/single_rc_model/figures.json); test_model_compatibility.py replays them."""
from dataclasses import replace
from pathlib import Path

import yaml

from battery_simulator.core.battery_model import BatteryModel
from battery_simulator.core.battery_parameters import BatteryParameters
from battery_simulator.core.battery_states import Mode
from battery_simulator.core.config_files import from_mapping

DATA = Path(__file__).resolve().parents[1] / 'data' / 'single_rc_model'
#: every KEEP-th row of a run is saved, and its last
KEEP = 20


def single_rc_cell():
    """The lg_hg2_cell preset as it was before issue 25 (no key of the two-RC model)."""
    values = yaml.safe_load((DATA / 'lg_hg2_cell.yaml').read_text(encoding='utf-8'))
    # saved before the held-full charger (Part 7), which changes only the current shown at Full on the dock
    return from_mapping(dict(values, charger_holds_full=False), base=BatteryParameters())


def _trace(model, steps):
    rows = []
    for dt_s, step_args in steps:
        model.step(dt_s, **step_args)
        rows.append([model.voltage_v, model.current_a, model.state_of_charge, model.temperature_c,
                     model.rc_voltage_v, model.status.value])
    return rows[::KEEP] + rows[-1:]


def runs():
    """Each run's name and its rows (voltage, current, SOC, temperature, RC voltage, status)."""
    cell = single_rc_cell()
    pack = replace(cell, cells_series=3, cells_parallel=2, charge_current_a=3.0, load_current_a=2.0,
                   load_power_w=5.0)
    out = {}
    model = BatteryModel(cell, state_of_charge=0.9, mode=Mode.IDLE)
    currents = [-1.5] * 300 + [-0.3] * 100 + [2.0] * 200 + [-6.0] * 2000
    out['cell_replay'] = _trace(model, [(7.0, {'current_a': c}) for c in currents])
    model = BatteryModel(pack, state_of_charge=0.95, mode=Mode.DISCHARGE)
    rows = _trace(model, [(10.0, {})] * 1500)
    model.set_mode(Mode.CHARGE)
    rows += _trace(model, [(10.0, {})] * 2000)
    model.set_mode(Mode.DISCHARGE)
    rows += _trace(model, [(30.0, {'power_w': -40.0})] * 300)
    out['pack_modes'] = rows
    out['pack_export'] = model.export_state()
    model = BatteryModel(BatteryParameters(ambient_temperature_c=0.0, charger_holds_full=False), state_of_charge=0.5, mode=Mode.CHARGE)
    out['default_cold_charge'] = _trace(model, [(60.0, {})] * 200)
    return out


if __name__ == '__main__':   # run once with the single-RC model to save its figures
    import json
    (DATA / 'figures.json').write_text(json.dumps(runs()), encoding='utf-8')
