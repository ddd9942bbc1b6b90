"""Events a robot can see (issue 43 item 3, interface Part 9): a learning gauge's correction larger than one
point is logged once (old -> new, why) through core/battery.py, as both front ends and the fleet hosts use it,
and counted in the diagnostics (Gauge Corrections, Gauge Full Capacity (Ah), Gauge Learned); its own end of
charge is FULL on battery_status. No ROS: a clock and a log of the test's own."""
from types import SimpleNamespace

import pytest

from battery_simulator.core.battery import Battery
from battery_simulator.core.battery_states import Mode, Status
from battery_simulator.core.config_files import from_mapping
from battery_simulator.core.diagnostics import battery_values
from battery_simulator.core.status_codes import DIAGNOSTIC_KEYS, SupplyStatus

ONE_C = 2.781 * 1


class Clock:
    def __init__(self):
        self.now = 0.0

    def __call__(self):
        return self.now


class Log:
    def __init__(self):
        self.lines = []

    def info(self, text, *args):
        self.lines.append(text % args)

    warn = error = info


def battery(percentage, charging=False, **gauge):
    params = from_mapping({'preset': 'lg_hg2_3s1p', 'load_current_a': ONE_C,
                           'gauge': dict({'model': 'learning'}, **gauge)})
    clock, log = Clock(), Log()
    return Battery(params, percentage, charging, clock=clock, log=log), clock, log


def run(battery_, clock, seconds, update_s=10.0):
    end = clock.now + seconds
    while clock.now < end:
        clock.now += update_s
        update = battery_.update()
    return update.record


def diagnostics(record):
    state = SimpleNamespace(battery=SimpleNamespace(**record.battery_fields()), **record.sim_fields())
    return dict(battery_values(state))


def test_a_rest_correction_is_logged_once_and_counted():
    battery_, clock, log = battery(50.0)
    battery_.set_mode(Mode.IDLE, 'test')
    battery_.set_state(gauge_error=5.0)
    record = run(battery_, clock, 1750.0)
    assert diagnostics(record)['Gauge Corrections'] == '0' and not log.lines
    record = run(battery_, clock, 3600.0)   # read at 30 min, again every 100 s: one correction
    corrections = [line for line in log.lines if line.startswith('gauge ocv_rest')]
    assert len(corrections) == 1, log.lines
    assert corrections[0].startswith('gauge ocv_rest: 55.0 % -> 49.4 % (rest of 30 min: open-circuit 3.'), corrections
    values = diagnostics(record)
    assert list(values) == list(DIAGNOSTIC_KEYS)
    assert values['Gauge Corrections'] == '1' and values['Gauge Learned'] == 'false'
    assert values['Gauge Full Capacity (Ah)'] == '%.3f' % 2.781


def test_a_learned_capacity_shows_in_the_diagnostics_and_the_log():
    battery_, clock, log = battery(100.0, capacity_error=0.1)
    record = run(battery_, clock, 1.0, update_s=1.0)
    assert diagnostics(record)['Gauge Full Capacity (Ah)'] == '%.3f' % (1.1 * 2.781)
    for mode, seconds in ((Mode.IDLE, 7200.0), (Mode.DISCHARGE, 4000.0), (Mode.IDLE, 7200.0)):
        battery_.set_mode(mode, 'test')
        record = run(battery_, clock, seconds)
    values = diagnostics(record)
    assert values['Gauge Learned'] == 'true', log.lines
    assert abs(float(values['Gauge Full Capacity (Ah)']) / 2.781 - 1.0) < 0.02
    learned = [line for line in log.lines if line.startswith('gauge capacity_learned: full capacity 3.059 Ah -> ')]
    assert len(learned) == 1, log.lines


def test_the_gauges_own_end_of_charge_is_full_on_battery_status():
    battery_, clock, log = battery(90.0, charging=True)
    statuses = []
    while clock.now < 20000.0:
        record = run(battery_, clock, 1.0, update_s=1.0)
        statuses.append((record.snapshot.status, record.power_supply_status, record.percentage))
        if record.snapshot.status is Status.FULL and record.power_supply_status == SupplyStatus.FULL:
            break
    assert statuses[-1][2] == 1.0
    shown_full = [(truth, percentage) for truth, status, percentage in statuses if status == SupplyStatus.FULL]
    assert all(percentage == 1.0 for _, percentage in shown_full), 'FULL only with 100 %'
    assert all(status != SupplyStatus.FULL for _, status, percentage in statuses if percentage < 1.0)


@pytest.mark.parametrize('gauge', [None, {'model': 'coulomb_counter'}])
def test_other_gauges_show_no_corrections_and_the_packs_capacity(gauge):
    params = from_mapping(dict({'preset': 'lg_hg2_3s1p'}, **({'gauge': gauge} if gauge else {})))
    clock = Clock()
    record = run(Battery(params, 80.0, clock=clock), clock, 10.0)
    values = diagnostics(record)
    assert (values['Gauge Corrections'], values['Gauge Learned']) == ('0', 'false')
    assert values['Gauge Full Capacity (Ah)'] == '%.3f' % record.snapshot.capacity_ah
