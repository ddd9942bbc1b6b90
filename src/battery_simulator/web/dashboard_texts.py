"""The dashboard's texts, without ROS: a BatteryState's codes as the page's words, and each number as the
page shows it (units, digits, out of range, durations), in the order a person sorts topics."""
import functools
import re

from battery_simulator.core import status_codes
from battery_simulator.core.parameter_rules import is_number

#: sensor_msgs/BatteryState.power_supply_status -> the page's status
SUPPLY_STATUS = status_codes.SUPPLY_STATUS_TEXT
#: BatterySimState.charging_state -> the page's status (the simulator knows Empty): the page writes
#: "Not charging" as a sentence, the simulator's texts are the diagnostics' "Not Charging"
SIM_CHARGING_STATE = {state: state.capitalize() for state in status_codes.CHARGING_STATES}
#: sensor_msgs/BatteryState.power_supply_health: the diagnostics' texts; unknown is '-' as every unknown field
SUPPLY_HEALTH = {code: text for code, text in status_codes.HEALTH_TEXT.items() if code != status_codes.SupplyHealth.UNKNOWN}

#: beyond this magnitude a number is shown in scientific notation (3 significant digits): a driver's
#: 3.4e38 would otherwise be a 40-digit number overflowing the card
MAX_FIXED = 1e5
#: what a battery can plausibly report, (low, high) inclusive; a value outside is shown marked "out of range"
#: (a voltage of 0 or below too: no pack reads that; NaN is the message's "not measured")
PLAUSIBLE = {'percentage': (0.0, 100.0), 'voltage': (0.0, 1000.0), 'current': (-1000.0, 1000.0),
             'temperature': (-60.0, 150.0), 'charge': (0.0, 1e4), 'capacity': (0.0, 1e4),
             'cycle_count': (0.0, 1e6), 'state_of_health': (0.0, 100.0)}
ABOVE_LOW = ('voltage',)   # fields whose low bound itself is out of range
OUT_OF_RANGE = ' (out of range)'
_DIGITS = re.compile(r'[0-9]+')
MAX_DURATION_H = 9999      # a longer time remaining is shown as "> 9999 h"


@functools.lru_cache(maxsize=8192)   # every view of every battery carries it: 1000 a second at 1000 robots
def natural_key(topic):
    """A string whose plain (code point) order is the natural order of topic names: each run of digits
    becomes its length (3 digits) and then its digits, leading zeros dropped, so that '/robot2/...' sorts
    before '/robot10/...'. The model sorts by it and the page places its cards by it (the view's
    'order'), so both show one order."""
    return _DIGITS.sub(lambda match: '%03d%s' % (len(match.group().lstrip('0') or '0'),
                                                  match.group().lstrip('0') or '0'), topic)


def in_range(field, value):
    """A finite ``value`` of ``field`` (percentage in %) within PLAUSIBLE."""
    low, high = PLAUSIBLE[field]
    return is_number(value) and (low < value if field in ABOVE_LOW else low <= value) and value <= high


def number_text(value, digits, unit, field=None):
    """'12.31 V'; '3.4e+38 V' beyond MAX_FIXED; ' (out of range)' appended outside PLAUSIBLE[field];
    '-' for NaN, infinity or nothing."""
    if not is_number(value):
        return '-'
    text = '%.*f' % (digits, value) if abs(value) < MAX_FIXED else '%.3g' % value
    if unit:
        text += ' ' + unit
    if field is not None and not in_range(field, value):
        text += OUT_OF_RANGE
    return text


def percentage_text(fraction):
    """BatteryState.percentage (0..1) as '63.2 %'."""
    return number_text(100.0 * fraction if is_number(fraction) else None, 1, '%', 'percentage')


def duration_text(seconds):
    """'2 h 05 min', '7 min', '40 s'; '-' when unknown."""
    if not is_number(seconds) or seconds < 0:
        return '-'
    if seconds < 60:
        return '%d s' % seconds
    minutes = int(round(seconds / 60.0))
    if minutes < 60:
        return '%d min' % minutes
    if minutes >= 60 * MAX_DURATION_H:
        return '> %d h' % MAX_DURATION_H
    return '%d h %02d min' % divmod(minutes, 60)


def json_number(value):
    """A number JSON can carry (NaN and infinities become null)."""
    return float(value) if is_number(value) else None
