"""Issue 43's end-of-charge figures (interface Part 9) on every preset, with each gauge preset: 99 % held through
the CV taper until at most 120 s before the charger terminates, 100 % at the latest 90 s after it, and a charge
stopped 0.5 % of capacity before its termination shows 99 %, not 100 %. test_learning_gauge.py checks them in
detail on the default pack; here every pack of config/presets, and the charger's own termination rule on a pack
of differing groups that balancing bleeds (lg_hg2_7s4p_aged). No ROS."""
import pytest

from battery_simulator.core.battery_states import Mode, Status
from battery_simulator.core.config_files import from_mapping, gauge_preset_names, preset, preset_names
from battery_simulator.core.pack import make_model
from gauge_charges import charge_watch

#: each pack with the plain learning gauge (None) and each gauge preset
GAUGES = [None] + gauge_preset_names()
START_SOC = 0.2
DT_S = 2.0


def learning(pack, gauge):
    return from_mapping({'preset': pack, 'gauge': {'model': 'learning'} if gauge is None else {'preset': gauge}})


def charge(params, stop_at_as=None):
    """From START_SOC: (the model, then gauge_charges.charge_watch's four figures)."""
    model = make_model(params, START_SOC, Mode.IDLE)
    return (model,) + charge_watch(model, DT_S, stop_at_as)


@pytest.mark.parametrize('gauge', GAUGES)
@pytest.mark.parametrize('pack', preset_names())
def test_every_pack_holds_99_percent_until_the_chargers_termination_and_stops_short_at_99(pack, gauge):
    """Measured (1 s steps, from 20 %): 100 % 19-79 s after the termination on every pack (ModelGauge's band up to
    1.25x the termination current: 7 s before it on kobuki_4s2p and lg_hg2_7s4p). Before the pack's charger took
    its termination current as the end (pack.py GroupedPack._terminates), lg_hg2_7s4p_aged's gauge showed 100 %
    11532 s before the model's Full (its string held at the 0.05 A bleed for 3.2 h), and a charge stopped 0.5 %
    before that Full showed 100 %."""
    params = learning(pack, gauge)
    _, hundred, terminated, highest, total_as = charge(params)
    assert terminated is not None and hundred is not None, (terminated, hundred)
    assert terminated - 120.0 <= hundred <= terminated + 90.0, (hundred, terminated)
    assert 98.0 <= highest <= 99.0, 'held at 99 % (or the gauge just below it) until the end of charge'

    stopped, hundred, terminated, highest, _ = charge(params, stop_at_as=total_as - 0.005 * params.design_capacity_ah
                                                      * 3600.0)
    shown = stopped.gauge_reading()[0]
    assert terminated is None and hundred is None, 'stopped before the termination: never 100 %'
    # 99 % (the hold); the plain gauge (no sensor error) on a123_lfp_cell reads its count there, 98.8 %: that
    # pack's charge ends at SOC 0.992 (the truth is 98.7 % 0.5 % before it)
    assert 98.5 <= shown <= 99.0 and shown >= min(99.0, 100.0 * stopped.state_of_charge) - 0.2, \
        (shown, stopped.state_of_charge)


def test_a_balancing_pack_ends_its_charge_at_the_termination_current():
    """lg_hg2_7s4p_aged: its fullest group allows only what fills it, balancing bled that much (0.05 A) past it,
    so it never filled, and the string ran at 0.05 A, a quarter of the 0.2 A termination, from 7040 s to
    18651 s from 20 %, CHARGING. A charger ends its CV phase when its own current falls to the termination
    current: Full in the step the string reaches it."""
    params = preset('lg_hg2_7s4p_aged')
    model = make_model(params, START_SOC, Mode.CHARGE)
    t = 0.0
    while model.status is not Status.FULL and t < 40000.0:
        model.step(DT_S)
        t += DT_S
        if model.status is Status.CHARGING and model.current_a < params.charge_current_a:
            assert model.current_a > params.pack_termination_current_a, (t, model.current_a)
    assert model.status is Status.FULL and t < 7500.0, t
    assert model.state_of_charge > 0.995 and max(g.state_of_charge for g in model.groups) > 0.9999, \
        'the fullest group is full'
