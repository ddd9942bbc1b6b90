"""Scenarios whose figures were saved from the lumped model before the pack of groups and the gauge
existed (test/data/lumped_model_figures.json, written by ``python3 test/core/pack_scenarios.py``):
with no spread and an ideal gauge the model must give them again to 1e-9."""
import json
import os
import sys
from dataclasses import replace

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), '..', '..', 'src'))

from battery_simulator.core.battery_states import Mode  # noqa: E402
from battery_simulator.core.config_files import preset  # noqa: E402
from battery_simulator.core.pack import make_model  # noqa: E402

FIGURES = os.path.join(os.path.dirname(os.path.abspath(__file__)), '..', 'data', 'lumped_model_figures.json')


def scenario(name):
    """[(t, percentage, voltage, current, temperature, status)] of one scenario."""
    preset_name, soc, mode, steps = {
        'discharge_3s1p': ('lg_hg2_3s1p', 1.0, Mode.DISCHARGE, [(10.0, {})] * 800),
        'charge_7s4p': ('lg_hg2_7s4p', 0.2, Mode.CHARGE, [(10.0, {})] * 1200),
        'power_kobuki': ('kobuki_4s2p', 0.9, Mode.IDLE, [(5.0, {'power_w': -40.0})] * 600
                         + [(5.0, {'current_a': 2.0})] * 300),
    }[name]
    # saved before the held-full charger (Part 7), which changes only the current shown at Full on the dock
    model = make_model(replace(preset(preset_name), charger_holds_full=False), state_of_charge=soc, mode=mode)
    rows, t = [], 0.0
    for dt_s, load in steps:
        model.step(dt_s, **load)
        t += dt_s
        s = model.snapshot()
        rows.append([t, s.percentage, s.voltage_v, s.current_a, s.temperature_c, s.status.value])
    return rows


NAMES = ('discharge_3s1p', 'charge_7s4p', 'power_kobuki')

if __name__ == '__main__':
    with open(FIGURES, 'w') as stream:
        json.dump({name: scenario(name) for name in NAMES}, stream)
