"""battery_state_pub's rules (core/status_rules.py), for both front ends: alarms, send now, dropout, the
diagnostic report, and the conventions a driver is emulated with (on a copy)."""
from types import SimpleNamespace

from battery_simulator.core.status_rules import StatusRules, conventions_of

FULL, CHARGING, DISCHARGING = 4, 1, 2


class Log:
    def __init__(self):
        self.lines = []

    def info(self, text, *args):
        self.lines.append(text % args)

    warn = info

    def info_throttle(self, period, text, *args):
        self.lines.append(text % args)

    warn_throttle = info_throttle


def state(percentage, status=DISCHARGING, current=-1.5, dropout=False, **sim):
    battery = SimpleNamespace(percentage=percentage, power_supply_status=status, current=current,
                              serial_number='SIM-1', voltage=11.5, cell_voltage=[3.8, 3.8, 3.8])
    message = SimpleNamespace(battery=battery, sensor_dropout=dropout, **sim)
    return SimpleNamespace(percentage=percentage, power_supply_status=status, sensor_dropout=dropout,
                           message=lambda: message)


def rules(log=None):
    return StatusRules(3.0, 0.20, 0.05, 0.05, log or Log(), 'the server', 'the server')


def test_the_alarms_change_with_hysteresis_and_are_said():
    log = Log()
    status = rules(log)
    assert status.take(state(0.5)).alarm_changes == []
    assert status.take(state(0.19)).alarm_changes == [('low', True)]
    assert status.take(state(0.04)).alarm_changes == [('critical', True)]
    assert status.take(state(0.09)).alarm_changes == []            # within the hysteresis
    assert status.take(state(0.11)).alarm_changes == [('critical', False)]
    assert status.take(state(0.26)).alarm_changes == [('low', False)]
    assert 'battery low: True at 19.0 %' in log.lines


def test_a_status_change_or_a_service_goes_out_at_once():
    status = rules()
    assert not status.take(state(0.5)).publish_now            # nothing published yet: no change to send
    assert status.to_publish().percentage == 0.5
    assert not status.take(state(0.49)).publish_now
    assert status.take(state(0.49, status=CHARGING, current=1.0)).publish_now
    assert status.take(state(0.49), publish_now=True).publish_now


def test_nothing_before_the_first_state_or_under_a_dropout():
    status = rules()
    assert status.to_publish() is None and status.latest_battery() is None
    assert status.diagnostic().hardware_id == 'none'
    status.take(state(0.5, dropout=True))
    assert status.to_publish() is None and status.latest_battery() is None


def test_conventions_change_a_copy_of_what_goes_out_only():
    status = rules()
    gazebo_like = state(0.5, status=CHARGING, current=2.0, invert_current_sign=True, percentage_scale=100.0)
    status.take(gazebo_like)
    out = status.to_publish()
    assert (out.current, out.percentage) == (-2.0, 50.0)
    kept = gazebo_like.message().battery
    assert (kept.current, kept.percentage) == (2.0, 0.5), 'the alarms and diagnostics read the original'
    plain = state(0.5, invert_current_sign=False, percentage_scale=1.0)
    status.take(plain)
    assert status.to_publish() is plain.message().battery       # no copy without conventions
    assert conventions_of(SimpleNamespace()) == {}              # a message from before the fields: none
    assert conventions_of(SimpleNamespace(invert_current_sign=False, percentage_scale=0.0)) == {}
