"""The prediction (core/prediction.py) and battery_replay.py --charge, against hand numbers and fine steps."""
import csv
import io
import math

import pytest

from dataclasses import replace

from battery_simulator.core.battery_model import BatteryModel
from battery_simulator.core.battery_states import Mode, Status
from battery_simulator.core.config_files import load_yaml, preset
from battery_simulator.core.pack import make_model
from battery_simulator.core.prediction import (CHECKPOINT_SEGMENTS, MAX_PLAN_S, MAX_SEGMENTS, PredictionError,
                                               Segment, plan_from_arrays, predict)
from battery_simulator.core.replay import OUTPUT_COLUMNS
from test_replay import SOURCE, run_cli

NAN = float('nan')
PACK = preset('lg_hg2_3s1p')   # 2.78 Ah, base load 1.5 A, charger 1.5 A, 50 W per m/s, 4 W per rad/s
#: demo.launch gauge:=realistic: PACK in three groups that differ, and a coulomb counter that starts 2 points
#: high, believes 6 % more capacity than the truth, and counts a 20 mA offset and a 1 % gain error
REALISTIC = SOURCE.parent / 'config' / 'battery_realistic.yaml'


def pack(percentage, mode=Mode.DISCHARGE, params=PACK):
    return BatteryModel(params, state_of_charge=percentage / 100.0, mode=mode)


def stepped(model, segments, step_s=1.0):
    """The reference: the plan in fixed steps (as a server at 10 Hz and time x10), and its cut-off time."""
    model.set_mode(Mode.DISCHARGE)
    time_s, cut_off_s = 0.0, NAN
    for segment in segments:
        model.set_extra_load('plan', current_a=segment.current_a, power_w=segment.power_w
                             + model.params.motion_power_w(segment.speed_mps, segment.turn_radps))
        for _ in range(int(round(segment.duration_s / step_s))):
            model.step(step_s)
            time_s += step_s
            if model.status is Status.EMPTY and math.isnan(cut_off_s):
                cut_off_s = time_s
    return model, cut_off_s


def charged(model, target_percentage, step_s=1.0):
    """The reference charge time in fixed steps: until the robot reads the level (the gauge's: the truth
    with an ideal gauge) or the pack is Full."""
    model.set_mode(Mode.CHARGE)
    time_s = 0.0
    while not (model.status is Status.FULL or model.gauge_reading()[0] >= target_percentage):
        model.step(step_s)
        time_s += step_s
    return time_s


# -- the requests ----------------------------------------------------------------

@pytest.mark.parametrize('arrays, message', [
    (dict(duration_s=[1, 2, 3], current_a=[1, 2]),
     'current_a has 2 entries but duration_s has 3: the arrays must have one length (an empty array counts as zeros)'),
    (dict(duration_s=[10, 20, -1]), 'duration_s[2] = -1 is invalid: must be a number of seconds >= 0'),
    (dict(duration_s=[NAN]), 'duration_s[0] = nan is invalid: must be a number of seconds >= 0'),
    (dict(duration_s=[math.inf]), 'duration_s[0] = inf is invalid: must be a number of seconds >= 0'),
    (dict(duration_s=[MAX_PLAN_S, 1.0]),
     'duration_s totals 604801 s, which is invalid: a plan is at most 604800 s (7 days)'),
    # the exact figures (%g printed "totals 604800 s ... at most 604800 s")
    (dict(duration_s=[MAX_PLAN_S, 0.5]),
     'duration_s totals 604800.5 s, which is invalid: a plan is at most 604800 s (7 days)'),
    (dict(duration_s=[MAX_PLAN_S, 1e-6]),
     'duration_s totals 604800.000001 s, which is invalid: a plan is at most 604800 s (7 days)'),
    (dict(duration_s=[1e308, 1e308]),   # a total beyond floats (was an OverflowError)
     'duration_s totals inf s, which is invalid: a plan is at most 604800 s (7 days)'),
    (dict(duration_s=[1.0] * 10, power_w=[0.0] * (MAX_SEGMENTS + 1)),
     'power_w has 100001 entries, which is invalid: a plan has at most 100000 segments (a day at one-second '
     'resolution)'),
    (dict(duration_s=[1, 2], current_a=[0, True]), 'current_a[1] = True is invalid: must be a number of amperes >= 0 '
     '(a load)'),
    (dict(duration_s=[1], current_a=[-0.5]),
     'current_a[0] = -0.5 is invalid: must be a number of amperes >= 0 (a load)'),
    (dict(duration_s=[1, 1], power_w=[5, NAN]), 'power_w[1] = nan is invalid: must be a number of watts >= 0 (a load)'),
    (dict(duration_s=[1], speed_mps=[51]), 'speed_mps[0] = 51 is invalid: must be a number in [-50, 50] m/s'),
    (dict(turn_radps=[math.inf]), 'turn_radps[0] = inf is invalid: must be a number in [-50, 50] rad/s'),
])
def test_bad_arrays_name_the_field_the_index_and_what_is_allowed(arrays, message):
    with pytest.raises(PredictionError) as error:
        plan_from_arrays(**arrays)
    assert str(error.value) == message


def test_a_plan_may_have_max_segments_a_day_at_one_second_resolution():
    plan = plan_from_arrays(duration_s=[1.0] * MAX_SEGMENTS, current_a=[0.5] * MAX_SEGMENTS)
    assert MAX_SEGMENTS >= 86400 and len(plan) == MAX_SEGMENTS and plan[-1] == Segment(1.0, 0.5)
    assert plan_from_arrays(duration_s=[2, 3]) == (Segment(2.0), Segment(3.0)), 'whole numbers are numbers'


def test_empty_arrays_count_as_zeros_and_signed_motion_counts_as_cmd_vel_does():
    assert plan_from_arrays(duration_s=[60, 30], speed_mps=[0.2, -0.1]) == (
        Segment(60.0, 0.0, 0.0, 0.2, 0.0), Segment(30.0, 0.0, 0.0, -0.1, 0.0))
    assert plan_from_arrays() == ()
    assert plan_from_arrays(duration_s=[MAX_PLAN_S]) == (Segment(MAX_PLAN_S),)


@pytest.mark.parametrize('segment, charge_to, message', [
    (Segment(60, current_a=19.0), NAN, 'current_a[0] = 19.0 is invalid: must be in [0, 18.5] A (with the base load '
     'of 1.5 A, at most the 20 A the pack can deliver)'),
    (Segment(60, power_w=300.0), NAN, 'power_w[0] = 300.0 is invalid: must be a number in [0, 252] W (the most the '
     'pack can deliver)'),
    (Segment(60, power_w=200.0, speed_mps=2.0), NAN, 'power_w[0] + the motion of speed_mps[0] and turn_radps[0] = '
     '300.0 is invalid: must be a number in [0, 252] W (the most the pack can deliver)'),
    (Segment(60), 101.0, 'charge_to_percentage = 101.0 is invalid: must be in [0, 100] % (0 or NaN: no charge)'),
    (Segment(60), -math.inf, 'charge_to_percentage = -inf is invalid: must be in [0, 100] % (0 or NaN: no charge)'),
    # segments given to predict() itself are checked as Predict.srv's arrays are (plan_from_arrays); before, a
    # negative or NaN current and a negative or NaN duration were taken as they were, and an infinite one hung
    (Segment(60, current_a=-1.0), NAN, 'current_a[0] = -1.0 is invalid: must be a number of amperes >= 0 (a load)'),
    (Segment(60, current_a=NAN), NAN, 'current_a[0] = nan is invalid: must be a number of amperes >= 0 (a load)'),
    (Segment(-60), NAN, 'duration_s[0] = -60 is invalid: must be a number of seconds >= 0'),
    (Segment(NAN), NAN, 'duration_s[0] = nan is invalid: must be a number of seconds >= 0'),
    (Segment(math.inf), NAN, 'duration_s[0] = inf is invalid: must be a number of seconds >= 0'),
    (Segment(MAX_PLAN_S + 1.0), NAN, 'duration_s totals 604801 s, which is invalid: a plan is at most 604800 s (7 days)'),
])
def test_loads_beyond_the_pack_and_bad_levels_are_refused(segment, charge_to, message):
    with pytest.raises(PredictionError) as error:
        predict(pack(80), [segment], charge_to)
    assert str(error.value) == message


def test_the_payloads_count_against_the_pack_limit_as_set_load_counts_them():
    model = pack(80)
    model.set_extra_load('payload', power_w=200.0)
    predict(model, [Segment(60, power_w=52.0)])
    with pytest.raises(PredictionError) as error:
        predict(model, [Segment(60, power_w=53.0)])
    assert str(error.value) == ('power_w[0] = 53 W is invalid: with the base load and the payloads (200 W) it '
                                'would total 253 W, beyond the 252 W the pack can deliver')


# -- what it predicts ------------------------------------------------------------

def test_an_hour_at_the_base_load_ends_where_coulomb_counting_says():
    result = predict(pack(100), [Segment(3600)])
    # 1.5 A for 1 h out of 2.78 Ah: 54.0 percentage points
    assert result.end_percentage == pytest.approx(100.0 - 100.0 * 1.5 / 2.78, abs=0.05)
    assert result.feasible and math.isnan(result.cut_off_at_s) and math.isnan(result.charge_time_s)
    # a current plan is exact in whole-segment steps: the same as 1 s steps
    reference, _ = stepped(pack(100), [Segment(3600)])
    assert result.end_percentage == pytest.approx(100.0 * reference.state_of_charge, abs=0.01)
    assert result.end_voltage_v == pytest.approx(reference.voltage_v, abs=0.01)


def test_a_current_adds_to_the_base_load():
    result = predict(pack(100), [Segment(1800, current_a=1.0)])
    assert result.end_percentage == pytest.approx(100.0 - 100.0 * 2.5 * 0.5 / 2.78, abs=0.05)


def test_the_motion_load_is_cmd_vel_s_drive_and_turn_power():
    motion = predict(pack(90), [Segment(1200, speed_mps=0.2, turn_radps=-1.0)])
    power = predict(pack(90), [Segment(1200, power_w=0.2 * 50.0 + 1.0 * 4.0)])
    assert motion == power
    assert motion.end_percentage < predict(pack(90), [Segment(1200)]).end_percentage - 5.0


def test_the_payloads_of_the_model_apply():
    model = pack(90)
    model.set_extra_load('payload', power_w=15.0)
    assert predict(model, [Segment(1200)]) == predict(pack(90), [Segment(1200, power_w=15.0)])


def test_large_steps_agree_with_one_second_steps():
    plan = [Segment(600, power_w=10.0), Segment(900, speed_mps=0.22, turn_radps=1.0), Segment(300, current_a=2.0),
            Segment(1200, power_w=5.0)]
    steps = []
    result = predict(pack(95), plan, observe=lambda time_s, model: steps.append(time_s))
    reference, cut_off_s = stepped(pack(95), plan)
    assert result.end_percentage == pytest.approx(100.0 * reference.state_of_charge, abs=0.05)
    assert result.feasible and math.isnan(cut_off_s)
    assert len(steps) < 400, 'an hour of power loads in %d steps: large steps, not 1 s' % len(steps)
    assert steps[-1] == pytest.approx(3000.0)


@pytest.mark.parametrize('start, segment', [
    (40, Segment(3000, power_w=20.0)),     # a power load: the knee of the OCV curve
    (100, Segment(7200, current_a=0.5)),   # a current: exact, the model bisects within the step
    (50, Segment(3000, power_w=60.0)),
])
def test_the_cut_off_time_agrees_with_fine_steps(start, segment):
    result = predict(pack(start), [segment, Segment(600)])
    _, cut_off_s = stepped(pack(start), [segment, Segment(600)], step_s=0.1)
    assert not result.feasible
    assert result.cut_off_at_s == pytest.approx(cut_off_s, rel=0.005)
    assert result.min_voltage_v == pytest.approx(3 * 2.8, abs=0.01), 'the cut-off voltage'
    assert result.end_percentage < 5.0


def test_a_pack_already_empty_is_cut_off_at_once():
    model = pack(0)
    assert model.status is Status.EMPTY
    result = predict(model, [Segment(60)])
    assert not result.feasible and result.cut_off_at_s == 0.0
    assert predict(model, [Segment(0)]).feasible, 'nothing to do: no cut-off'


def test_the_charge_time_has_the_cv_taper():
    result = predict(pack(20), [], 100.0)
    cc_only_s = 0.8 * 2.78 * 3600.0 / 1.5   # capacity over current: what a linear planner says
    assert result.charge_time_s > cc_only_s + 150.0, 'the CV taper takes its time'
    assert result.charge_time_s == pytest.approx(charged(pack(20), 100.0, step_s=0.1), rel=0.005)
    assert result.end_percentage == pytest.approx(20.0, abs=0.01), 'end_* is the end of the segments'


@pytest.mark.parametrize('start, target', [(20, 90), (60, 100), (0, 100), (90, 95)])
def test_charge_times_agree_with_fine_steps(start, target):
    result = predict(pack(start), [], target)
    assert result.charge_time_s == pytest.approx(charged(pack(start), target, step_s=0.1), rel=0.005)


def test_the_charge_follows_the_segments():
    plan = [Segment(1800, power_w=10.0)]
    after = predict(pack(80), plan)
    result = predict(pack(80), plan, 80.0)
    assert result.end_percentage == after.end_percentage
    reference, _ = stepped(pack(80), plan)
    assert result.charge_time_s == pytest.approx(charged(reference, 80.0, step_s=0.1), rel=0.005)


def test_charge_edge_cases():
    assert predict(pack(50), [], 40.0).charge_time_s == 0.0, 'already there'
    assert predict(pack(100), [], 100.0).charge_time_s == 0.0
    faulty = pack(50, Mode.CHARGE)
    faulty.set_charger_fault(True)
    result = predict(faulty, [], 60.0)
    assert math.isinf(result.charge_time_s)
    assert 'never' in result.summary()


def test_charge_to_percentage_0_the_message_default_means_no_charge_as_nan():
    result = predict(pack(50), [Segment(600)], 0.0)
    assert math.isnan(result.charge_time_s), 'was "charged in 0 s"'
    assert 'charged' not in result.summary()
    assert repr(result) == repr(predict(pack(50), [Segment(600)], NAN))


def test_segments_run_discharging_even_on_the_charger():
    docked = predict(pack(70, Mode.CHARGE), [Segment(600)])
    assert docked.end_percentage == pytest.approx(predict(pack(70), [Segment(600)]).end_percentage, abs=1e-9)
    assert docked.end_percentage < 70.0


def test_the_model_is_not_changed():
    model = pack(60)
    model.set_extra_load('payload', power_w=5.0)
    model.step(30.0)
    before = (model.export_state(), model.snapshot(), model.mode, model.extra_power_w)
    result = predict(model, [Segment(3000, power_w=60.0), Segment(600)], 100.0)
    assert not result.feasible and result.charge_time_s > 0
    assert (model.export_state(), model.snapshot(), model.mode, model.extra_power_w) == before


def test_the_extremes_cover_the_plan():
    result = predict(pack(90), [Segment(1200, power_w=80.0), Segment(1200)])
    assert result.max_temperature_c > 25.0 + 5.0, 'a 7 A load heats the pack'
    assert result.min_voltage_v < result.end_voltage_v, 'the voltage recovers once the load drops'


# -- battery_replay.py --charge --------------------------------------------------------

def test_cli_charge_from_20_percent_writes_the_usual_csv_and_says_how_long(tmp_path):
    out = tmp_path / 'charge.csv'
    result = run_cli('--charge', '1.5', '--soc', '0.2', '-o', out)
    assert result.returncode == 0, result.stderr
    rows = list(csv.DictReader(io.StringIO(out.read_text())))
    assert tuple(rows[0]) == OUTPUT_COLUMNS
    assert float(rows[0]['soc']) == pytest.approx(0.2) and float(rows[0]['time']) == 0.0
    assert rows[-1]['status'] == 'FULL' and float(rows[-1]['soc']) == 1.0
    assert max(float(r['current']) for r in rows) == pytest.approx(1.5)
    expected_s = predict(pack(20, Mode.IDLE), [], 100.0).charge_time_s
    assert float(rows[-1]['time']) == pytest.approx(expected_s, abs=0.01)
    assert result.stderr == ('battery_replay: lg_hg2_3s1p charged at 1.5 A from 20 %% to Full in %.0f s (1 h 51 min)\n'
                             % expected_s)
    assert len(rows) < 600, 'large steps (540 rows for 6667 s)'


def test_cli_charge_defaults_to_empty_and_takes_presets_and_refuses_bad_currents():
    result = run_cli('--charge', '4', '--preset', 'lg_hg2_7s4p')
    assert result.returncode == 0, result.stderr
    assert 'from 0 % to Full' in result.stderr
    assert list(csv.reader(io.StringIO(result.stdout)))[-1][5] == 'FULL'   # the status column
    result = run_cli('--charge', '10')
    assert result.returncode == 1
    assert result.stderr.strip() == ('battery_replay: --charge 10: parameter charge_current_a = 10.0 is invalid: '
                                     'must be at most 4 A (cell_max_charge_current_a x cells_parallel)')
    for bad in ('0', '-1', 'nan'):
        result = run_cli('--charge', bad)
        assert result.returncode == 2
        assert result.stderr.splitlines()[-1] == ('battery_replay.py: error: argument --charge: %s is not a current '
                                                  'in amperes > 0' % bad)


def test_cli_charge_or_a_profile_not_both(tmp_path):
    result = run_cli('--charge', '1.5', tmp_path / 'p.csv')
    assert result.returncode == 2
    assert result.stderr.splitlines()[-1] == 'battery_replay.py: error: give a profile CSV or --charge, not both'


def test_neighbouring_segments_of_one_load_are_one_segment():
    # 3600 one-second segments of one load cost one hour's few steps, not 3600 (the 50 ms budget)
    model = BatteryModel(preset('lg_hg2_3s1p'), 0.9)
    split = predict(model, plan_from_arrays([1.0] * 3600, [0.5] * 3600, [], [0.2] * 3600, [-0.1] * 3600))
    whole = predict(model, plan_from_arrays([3600.0], [0.5], [], [0.2], [0.1]))
    assert split == whole


@pytest.mark.parametrize('start, params, power_w, feasible', [
    (90, PACK, 25.0, True), (60, preset('lg_hg2_7s4p'), 150.0, True),
    (3, PACK, 5.0, False),    # cut off at 67 s: in the first checkpoint's segments
    (8, PACK, 25.0, False),   # at 152 s: the third's
])
def test_one_step_per_short_segment_gives_what_the_careful_steps_give_and_finds_the_cut_off_alike(start, params,
                                                                                                  power_w, feasible):
    """Segments of one second or less go in one step each (no look at the current before); a cut-off among
    them is redone from the last checkpoint with the careful steps (those an ``observe`` always gets)."""
    count = 3 * CHECKPOINT_SEGMENTS + 17
    arrays = dict(duration_s=[(0.5, 1.0, 0.25)[k % 3] for k in range(count)] + [600.0, 1.0],
                  current_a=[0.2 * (k % 4) for k in range(count)] + [0.5, 0.0],
                  power_w=[power_w * ((k * 37) % 11) / 10.0 for k in range(count)] + [0.0, 1.0],
                  speed_mps=[0.3 * (k % 2) for k in range(count)] + [0.0, 0.0], turn_radps=[0.0] * (count + 2))
    plan = plan_from_arrays(**arrays)
    model = BatteryModel(params, start / 100.0)
    fast = predict(model, plan, 90.0)
    careful = predict(model, plan, 90.0, observe=lambda time_s, m: None)
    assert fast.feasible == careful.feasible == feasible
    for name in ('end_percentage', 'end_voltage_v', 'min_voltage_v', 'max_temperature_c', 'cut_off_at_s',
                 'charge_time_s'):
        assert getattr(fast, name) == pytest.approx(getattr(careful, name), rel=1e-9, abs=1e-9, nan_ok=True), name


# -- the gauge's view (Part 5: everything a robot reads, predict's levels included) -------------------

def gauged(percentage, mode=Mode.IDLE):
    """The realistic pack at ``percentage`` (the truth; its gauge reads 2 points more)."""
    return make_model(load_yaml(str(REALISTIC)), state_of_charge=percentage / 100.0, mode=mode)


@pytest.mark.parametrize('start, target, gauge_ahead', [(90, 95, True), (90, 99, True), (50, 90, True),
                                                       (20, 90, False), (50, 100, False)])
def test_with_a_fuel_gauge_the_charge_ends_when_the_gauge_reads_the_level(start, target, gauge_ahead):
    """charge_to_percentage is the level the robot will read (the gauge's), not the truth's: the charge
    time agrees with the battery's own steps read through its gauge within Part 3's 2 % (from 90 % to
    95 % it was 308 s against 191 s: the truth is 2 points behind the gauge and gains on it slowly)."""
    result = predict(gauged(start), [], target)
    reference = gauged(start)
    reference_s = charged(reference, target, step_s=0.5)
    assert result.charge_time_s == pytest.approx(reference_s, rel=0.02), (result, reference_s)
    if gauge_ahead:   # from 20 % the gain error has let the truth catch up by 90 %
        assert reference.status is Status.CHARGING and reference.gauge_reading()[0] >= target
        assert 100.0 * reference.state_of_charge < target - 0.5, 'the truth is not there yet: the gauge decides'


def test_with_a_fuel_gauge_a_level_the_gauge_already_reads_takes_no_charge():
    model = gauged(90)
    assert model.gauge_reading()[0] == pytest.approx(92.0), 'initial_error: 2 points'
    assert predict(model, [], 91.0).charge_time_s == 0.0, 'the robot reads 92 %: already there'
    assert predict(model, [], 93.0).charge_time_s > 0.0


def test_with_a_fuel_gauge_end_percentage_is_what_the_gauge_reads():
    """Part 3's 1 point against the battery's own steps, on the gauge's percentage (not the truth's)."""
    plan = [Segment(1800, power_w=10.0, speed_mps=0.2), Segment(600, current_a=1.0)]
    result = predict(gauged(90), plan, 95.0)
    reference, cut_off_s = stepped(gauged(90), plan)
    assert result.feasible and math.isnan(cut_off_s)
    assert result.end_percentage == pytest.approx(reference.gauge_reading()[0], abs=1.0), result
    assert result.end_percentage > 100.0 * reference.state_of_charge + 2.0, 'the gauge reads high, not the truth'
    assert result.charge_time_s == pytest.approx(charged(reference, 95.0, step_s=0.5), rel=0.02)


def test_with_a_fuel_gauge_the_cut_off_agrees_and_the_gauge_reads_0_there():
    plan = [Segment(3000, power_w=20.0), Segment(600)]
    result = predict(gauged(40), plan)
    reference, cut_off_s = stepped(gauged(40), plan, step_s=0.1)
    assert not result.feasible
    assert result.cut_off_at_s == pytest.approx(cut_off_s, rel=0.02)
    assert result.end_percentage == reference.gauge_reading()[0] == 0.0, 'recalibrated at the cut-off'


def test_until_full_charges_to_full_whatever_the_gauge_reads():
    """A gauge that believes 10 % too little capacity and does not recalibrate at full reads 100 % before
    the pack is Full: the robot reads 100 % there (charge_to_percentage 100), battery_replay.py --charge
    goes on to Full (until_full)."""
    params = replace(PACK, gauge={'model': 'coulomb_counter', 'capacity_error': -0.1, 'recalibrate_at_full': False})
    to_100 = predict(make_model(params, 0.2), [], 100.0)
    to_full = predict(make_model(params, 0.2), [], until_full=True)
    assert to_100.charge_time_s == pytest.approx(charged(make_model(params, 0.2), 100.0, step_s=0.5), rel=0.02)
    assert to_full.charge_time_s == pytest.approx(predict(pack(20), [], 100.0).charge_time_s, rel=1e-9), \
        'the truth is the ideal pack\'s'
    assert to_100.charge_time_s < to_full.charge_time_s - 600.0


def test_cli_charge_says_where_a_gauge_started_and_ended(tmp_path):
    """--soc is the truth (the soc column), as a node's initial_percentage; the gauge starts where the
    config puts it (2 points high) and reads 100 % at Full (recalibrated)."""
    out = tmp_path / 'charge.csv'
    result = run_cli('--charge', '1.5', '--soc', '0.2', '--config', REALISTIC, '-o', out)
    assert result.returncode == 0, result.stderr
    rows = list(csv.DictReader(io.StringIO(out.read_text())))
    assert float(rows[0]['soc']) == pytest.approx(0.2) and float(rows[0]['gauge_soc']) == pytest.approx(0.22)
    assert rows[-1]['status'] == 'FULL' and float(rows[-1]['gauge_soc']) == 1.0
    expected_s = predict(gauged(20), [], until_full=True).charge_time_s
    assert float(rows[-1]['time']) == pytest.approx(expected_s, abs=0.01)
    assert result.stderr == ('battery_replay: lg_hg2_3s1p charged at 1.5 A from 20 %% to Full in %.0f s (%s); the '
                             'gauge read 22.0 %% then 100.0 %%\n' % (expected_s, '1 h 44 min'))


def test_cli_charge_with_a_learning_gauge_goes_on_to_the_gauges_own_end_of_charge(tmp_path):
    """Issue 43's end of charge in battery_replay's CSV: the rows ended at the charger's Full with the learning gauge
    at 99 % and no end_of_charge (the gauge's two 40 s windows end 75 s later on this pack), so a user never saw
    its 100 %. They go on, held full on the charger, to the gauge's end of charge; the time said is the
    charger's."""
    config = tmp_path / 'learning.yaml'
    config.write_text('preset: lg_hg2_3s1p\ngauge: {model: learning}\n')
    out = tmp_path / 'charge.csv'
    result = run_cli('--charge', '1.5', '--soc', '0.2', '--config', config, '-o', out)
    assert result.returncode == 0, result.stderr
    rows = list(csv.DictReader(io.StringIO(out.read_text())))
    terminated = next(float(row['time']) for row in rows if row['status'] == 'FULL')
    assert float(rows[-1]['gauge_soc']) == 1.0 and rows[-1]['gauge_event'] == 'end_of_charge', rows[-1]
    assert terminated < float(rows[-1]['time']) <= terminated + 90.0   # Part 9: 100 % at most 90 s after it
    assert all(float(row['gauge_soc']) <= 0.99 for row in rows[:-1])
    assert 'to Full in %.0f s' % terminated in result.stderr and 'then 100.0 %' in result.stderr, result.stderr


def test_a_pack_of_groups_filled_below_the_cv_onset_is_full_when_its_fullest_group_fills():
    """lg_hg2_7s4p_aged charged at 0.25 A: its fullest group fills (SOC 1) with the mean group's voltage below
    the CV onset, so the steps were CC's 600 s and Full came at a step's end: 15000 s from 90 % against 14775 s
    in 1 s steps. Now no charging step goes past the moment the pack fills: within a CV step."""
    params = replace(preset('lg_hg2_7s4p_aged'), charge_current_a=0.25, gauge=None)
    result = predict(make_model(params, 0.98), [], until_full=True)
    model, fine_s = make_model(params, 0.98, Mode.CHARGE), 0.0
    while model.status is not Status.FULL:
        model.step(1.0)
        fine_s += 1.0
    assert abs(result.charge_time_s - fine_s) <= 5.0, (result.charge_time_s, fine_s)
