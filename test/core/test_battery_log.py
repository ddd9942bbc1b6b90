"""core/battery_log.py's transitions (issue 40 item 8): every charger connect and disconnect is in the log,
none hidden by a throttle (the demo's 40-140 ms touch of the dock said "charger connected" and its
"disconnected" fell under the 1 s throttle), and a bouncing contact still writes at most about a line a
second: a change sooner than SETTLE_S after the last is counted, and said once the state stands."""
import re

import pytest

from battery_simulator.core import battery_log
from battery_simulator.core.battery_log import BatteryLog, SETTLE_S, BOUNCE_REPORT_S


@pytest.fixture
def clock(monkeypatch):
    now = [1000.0]
    monkeypatch.setattr(battery_log.time, 'monotonic', lambda: now[0])
    return now


def a_log():
    lines = []
    log = BatteryLog(lines.append, lines.append, lines.append, prefix='r1: ')
    return log, lines


def test_a_disconnect_right_after_a_connect_is_said(clock):
    """A touch of 0.05 s: connected said at once, the disconnect said once the contact stood, none lost."""
    log, lines = a_log()
    log.transition('%s: charger connected', 'charger contact')
    assert lines == ['r1: charger contact: charger connected']
    clock[0] += 0.05
    log.transition('%s: charger disconnected', 'charger contact')
    log.settle()
    clock[0] += SETTLE_S
    log.settle()
    assert len(lines) == 2 and lines[1].startswith('r1: charger contact: charger disconnected (after 1 change'), lines
    log.settle()
    assert len(lines) == 2


def test_changes_that_stand_are_each_said_at_once(clock):
    log, lines = a_log()
    for k in range(6):
        log.transition('charger %s', 'connected' if k % 2 == 0 else 'disconnected')
        log.settle()
        clock[0] += SETTLE_S + 0.01
    assert lines == ['r1: charger connected', 'r1: charger disconnected'] * 3


def test_the_same_format_twice_within_a_second_is_said_twice(clock):
    """Today's throttle kept one line a format a second: connect, disconnect, connect within 1 s lost the
    second connect. Each change is accounted for, the last state named."""
    log, lines = a_log()
    for k in range(3):
        log.transition('charger %s', 'connected' if k % 2 == 0 else 'disconnected')
        clock[0] += 0.3
    clock[0] += SETTLE_S
    log.settle()
    assert lines[0] == 'r1: charger connected'
    assert len(lines) == 2 and lines[1].startswith('r1: charger connected (after 2 change(s)'), lines


def test_a_contact_bouncing_for_a_minute_writes_a_line_every_report_period(clock):
    log, lines = a_log()
    changes = 0
    for k in range(60 * 500):   # 500 changes a second for 60 s, the server updating at 10 Hz
        log.transition('charger %s', 'connected' if k % 2 == 0 else 'disconnected')
        changes += 1
        clock[0] += 0.002
        if k % 50 == 0:
            log.settle()
    clock[0] += SETTLE_S
    log.settle()
    assert 1 + 60 / BOUNCE_REPORT_S - 1 <= len(lines) <= 2 + 60 / BOUNCE_REPORT_S, lines
    counted = 1 + sum(int(re.search(r'(\d+) change\(s\)', line).group(1)) for line in lines[1:])
    assert counted == changes, lines
    assert lines[-1].startswith('r1: charger disconnected (after'), lines[-1]
