"""What the dashboard knows about every battery, without ROS (no rospy, no messages).

The node hands in plain values (a BatteryState as a dict of numbers, a Bool, a
few fields of the simulator's state) with the wall time they arrived; the web
app reads formatted records and histories out. Every rule the page shows lives
here: topic discovery, stale, low / critical, time remaining, the text of each
field.
"""
import bisect
import collections
import functools
import re

from battery_simulator.core import names
from battery_simulator.core.parameter_rules import is_number
from battery_simulator.core.settings import PUBLISHER_SETTINGS

BATTERY_TYPE = 'sensor_msgs/BatteryState'
BOOL_TYPE = 'std_msgs/Bool'
SIM_STATE_TYPE = 'battery_simulator/BatterySimState'
FLEET_STATE_TYPE = 'battery_simulator/BatteryFleetState'

STALE_MIN_S = 3.0        # stale after no message for max(this, STALE_PERIODS periods)
STALE_PERIODS = 3
#: without a battery_low / battery_critical topic: battery_state_pub's default thresholds
LOW_FRACTION, CRITICAL_FRACTION = (next(s.default for s in PUBLISHER_SETTINGS if s.name == name)
                                   for name in ('low_percentage', 'critical_percentage'))
HISTORY_POINTS = 1200    # at most this many chart points per battery over ~history_s
PERIOD_SAMPLES = 8       # arrival intervals the period estimate takes the median of

#: sensor_msgs/BatteryState.power_supply_status -> the page's status
SUPPLY_STATUS = names.SUPPLY_STATUS_TEXT
#: BatterySimState.charging_state -> the page's status (the simulator knows Empty): the page writes
#: "Not charging" as a sentence, the simulator's texts are the diagnostics' "Not Charging"
SIM_CHARGING_STATE = {state: state.capitalize() for state in names.CHARGING_STATES}
#: sensor_msgs/BatteryState.power_supply_health: the diagnostics' texts; unknown is '-' as every unknown field
SUPPLY_HEALTH = {code: text for code, text in names.HEALTH_TEXT.items() if code != names.SupplyHealth.UNKNOWN}
#: the numbers a BatteryState gives (pack units: V, A, degC, Ah; percentage 0..1)
BATTERY_FIELDS = ('percentage', 'voltage', 'current', 'temperature', 'charge', 'capacity', 'design_capacity')
CHART_FIELDS = ('percentage', 'voltage', 'current', 'temperature')
#: the faults a simulated battery knows (the page gets them in its snapshot)
FAULTS = tuple(sorted(names.FAULTS))


# -- text ----------------------------------------------------------------------


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


# -- rules -----------------------------------------------------------------------

def stale_after_s(period_s):
    """No message for this long: stale (3 s or 3 periods, whichever is longer)."""
    return max(STALE_MIN_S, STALE_PERIODS * period_s) if is_number(period_s) else STALE_MIN_S


def level_flags(percentage, low_topic, critical_topic):
    """(low, critical): the battery_low / battery_critical topics where they said something,
    else the level below 20 % / 5 %."""
    known = is_number(percentage)
    low = low_topic if low_topic is not None else (known and percentage < LOW_FRACTION)
    critical = critical_topic if critical_topic is not None else (known and percentage < CRITICAL_FRACTION)
    return bool(low), bool(critical)


def status_name(power_supply_status, sim_charging_state=None, percentage=None):
    """Charging, Discharging, Full, Not charging or Empty ('-' when the publisher does not know).

    sensor_msgs/BatteryState has no Empty: the simulator's state says it; from a
    BatteryState alone, a pack not charging at 0 % is Empty."""
    if sim_charging_state in SIM_CHARGING_STATE:
        return SIM_CHARGING_STATE[sim_charging_state]
    name = SUPPLY_STATUS.get(power_supply_status, '-')
    if name == 'Not charging' and is_number(percentage) and percentage <= 0.0:
        return 'Empty'
    return name


def time_remaining_s(values, status):
    """To empty while discharging, to full while charging, at the present current (as the
    simulator computes it); None when the BatteryState lacks charge, capacity or current (a
    capacity of 0, as many drivers send for "not measured", counts as lacking) or one of them is out of
    range."""
    charge, capacity, current = values.get('charge'), values.get('capacity'), values.get('current')
    if not (in_range('charge', charge) and in_range('current', current) and in_range('capacity', capacity)
            and capacity > 0.0):
        return None
    if status == 'Discharging' and current < 0.0:
        return charge / -current * 3600.0
    if status == 'Charging' and current > 0.0 and capacity >= charge:
        return (capacity - charge) / current * 3600.0
    return None


def discover(published):
    """The batteries in the master's [(topic, type)] list, and what to subscribe for each.

    Returns {battery topic: {'low': topic, 'critical': topic, 'state': topic}} (only the
    extras that exist) and {fleet state topic: namespace of its host}. A battery's extras
    live in its namespace (``<ns>/battery_low``, ``<ns>/battery_critical``,
    ``<ns>/battery_simulator/state``); they belong to it when it is the namespace's
    ``battery_status`` or the namespace's only battery. A ``<ns>/battery_state`` beside a
    ``<ns>/battery_status`` is the simulator's twin of it (what opennav_docking reads): one battery, shown once.
    """
    types = {}
    for topic, topic_type in published:
        types[topic] = topic_type
    batteries = sorted(topic for topic, topic_type in types.items() if topic_type == BATTERY_TYPE
                       and not (topic.endswith('/battery_state')
                                and types.get(topic[:-len('battery_state')] + 'battery_status') == BATTERY_TYPE))
    per_namespace = collections.Counter(namespace_of(topic) for topic in batteries)
    found = {}
    for topic in batteries:
        namespace = namespace_of(topic)
        extras = {}
        if topic.endswith('/battery_status') or per_namespace[namespace] == 1:
            for key, name, wanted in (('low', 'battery_low', BOOL_TYPE), ('critical', 'battery_critical', BOOL_TYPE),
                                      ('state', 'battery_simulator/state', SIM_STATE_TYPE)):
                extra = namespace.rstrip('/') + '/' + name
                if types.get(extra) == wanted:
                    extras[key] = extra
        found[topic] = extras
    fleets = {topic: namespace_of(namespace_of(topic).rstrip('/'))
              for topic, topic_type in types.items() if topic_type == FLEET_STATE_TYPE}
    return found, fleets


def namespace_of(name):
    """'/robot3/battery_status' -> '/robot3/'; '/battery_status' -> '/'."""
    return name[:name.rstrip('/').rfind('/') + 1] or '/'


def _same_stamp(stamp, shown):
    """A known header stamp (not 0: a publisher that leaves it unset) equal to the one shown."""
    return is_number(stamp) and stamp > 0.0 and stamp == shown


def fleet_battery_topic(host_namespace, robot_name):
    """The battery_status topic of robot ``robot_name`` of a fleet host in ``host_namespace``."""
    return host_namespace + robot_name.strip('/') + '/battery_status'


# -- one battery -------------------------------------------------------------------

class BatteryRecord:
    """One battery topic: its latest values, extras, arrival times and history."""

    def __init__(self, topic, now):
        self.topic = topic
        self.values = {}               # BATTERY_FIELDS -> float (NaN as given)
        self.power_supply_status = 0
        self.power_supply_health = 0
        self.location = ''
        self.serial_number = ''
        self.low_topic = None          # what battery_low / battery_critical last said (None: no word)
        self.critical_topic = None
        self.sim = {}                  # from battery_simulator/state: charging_state, faults, ...
        self.host = ''                 # the fleet host that serves it, if any
        self.has_controls = False      # the simulator's services exist in its namespace
        self.discovered = now
        self.last_message = None       # wall time of the latest BatteryState (its own or a fleet host's)
        self.own_last = None           # wall time of the latest on its own topic
        self.stamp = None              # header stamp (s) of the latest BatteryState shown
        self.messages = 0
        self._intervals = collections.deque(maxlen=PERIOD_SAMPLES)
        self.history = collections.deque()   # (time, percentage %, voltage, current, temperature)

    def period_s(self):
        """The median interval between messages (None until two arrived)."""
        if not self._intervals:
            return None
        ordered = sorted(self._intervals)
        return ordered[len(ordered) // 2]

    def stale(self, now):
        last = self.last_message if self.last_message is not None else self.discovered
        return now - last >= stale_after_s(self.period_s())

    def own_topic_speaks(self, now):
        """Its own topic said something within the stale time (a fleet host's copy then adds nothing)."""
        return self.own_last is not None and now - self.own_last < stale_after_s(self.period_s())

    def on_battery(self, values, now, history_step_s):
        if self.last_message is not None and now > self.last_message:
            self._intervals.append(now - self.last_message)
        self.last_message = now
        self.messages += 1
        self.stamp = values.pop('stamp', None)
        self.power_supply_status = values.pop('power_supply_status', 0)
        self.power_supply_health = values.pop('power_supply_health', 0)
        self.location = values.pop('location', '')
        self.serial_number = values.pop('serial_number', '')
        self.values = values
        if not self.history or now - self.history[-1][0] >= history_step_s:
            percentage = values.get('percentage')
            self.history.append((now, 100.0 * percentage if is_number(percentage) else None,
                                 json_number(values.get('voltage')), json_number(values.get('current')),
                                 json_number(values.get('temperature'))))

    def trim(self, now, history_s):
        while self.history and self.history[0][0] < now - history_s:
            self.history.popleft()

    def status(self):
        return status_name(self.power_supply_status, self.sim.get('charging_state'), self.values.get('percentage'))

    def remaining_s(self, status):
        """The simulator's own figure where it gives one, else from charge, capacity and current."""
        if 'time_remaining_s' in self.sim:
            return self.sim['time_remaining_s'] if is_number(self.sim['time_remaining_s']) else None
        return time_remaining_s(self.values, status)

    def _shown_numbers(self):
        """Every number the page shows as text, by PLAUSIBLE's field (percentages in %)."""
        numbers = {field: self.values.get(field) for field in ('voltage', 'current', 'temperature', 'charge',
                                                                 'capacity')}
        for field, source, scale in (('percentage', self.values, 100.0), ('cycle_count', self.sim, 1.0),
                                     ('state_of_health', self.sim, 100.0)):
            value = source.get(field)
            numbers[field] = scale * value if is_number(value) else None
        return numbers

    def view(self, now):
        """What the page shows: text per data-field, classes, raw numbers, extras."""
        values = self.values
        status = self.status()
        low, critical = level_flags(values.get('percentage'), self.low_topic, self.critical_topic)
        remaining = self.remaining_s(status)
        percentage = values.get('percentage')
        return {
            'topic': self.topic,
            'name': self.topic.strip('/'),
            'fields': {
                'percentage': percentage_text(percentage),
                'status': status,
                'voltage': number_text(values.get('voltage'), 2, 'V', 'voltage'),
                'current': number_text(values.get('current'), 2, 'A', 'current'),
                'temperature': number_text(values.get('temperature'), 1, '°C', 'temperature'),
                'time_remaining': duration_text(remaining),
                'charge': number_text(values.get('charge'), 2, 'Ah', 'charge'),
                'capacity': number_text(values.get('capacity'), 2, 'Ah', 'capacity'),
                'health': SUPPLY_HEALTH.get(self.power_supply_health, '-'),
                # the simulator's (battery_simulator/state), '-' where none
                'cycle_count': number_text(self.sim.get('cycle_count'), 2, '', 'cycle_count'),
                'state_of_health': number_text(100.0 * self.sim['state_of_health']
                                               if is_number(self.sim.get('state_of_health')) else None,
                                               1, '%', 'state_of_health'),
            },
            'level': json_number(100.0 * percentage) if is_number(percentage) else None,
            'out_of_range': sorted(field for field, value in self._shown_numbers().items()
                                   if is_number(value) and not in_range(field, value)),
            'values': {field: json_number(values.get(field)) for field in ('voltage', 'current', 'temperature')},
            'low': low,
            'critical': critical,
            'stale': self.stale(now),
            'last_message': self.last_message,
            'period_s': self.period_s(),
            'host': self.host,
            'location': self.location,
            'serial_number': self.serial_number,
            'sim': {key: (json_number(value) if isinstance(value, float) else value)
                    for key, value in self.sim.items()},
            'controls': self.has_controls,
            'order': natural_key(self.topic),
        }


# -- every battery --------------------------------------------------------------------

class DashboardModel:
    """Every battery the dashboard shows. Not thread-safe: the node holds one lock around it."""

    def __init__(self, history_s):
        self.history_s = history_s
        self.history_step_s = history_s / HISTORY_POINTS
        self.records = {}
        self._changed = set()
        self._removed = set()
        self._stale = set()
        #: dropped for silence -> the header stamp of its last message: back only with a new message, not by
        #: being advertised nor by a fleet host repeating that last message
        self._silenced = {}

    def _record(self, topic, now, changed=True):
        record = self.records.get(topic)
        if record is None:
            record = self.records[topic] = BatteryRecord(topic, now)
            self._removed.discard(topic)
            changed = True
        if changed:
            self._changed.add(topic)
        return record

    def add(self, topic, now, has_controls=False):
        """A battery topic found on the master (one dropped for its silence stays away until it speaks)."""
        if topic in self._silenced:
            return
        record = self._record(topic, now, changed=False)
        if record.has_controls != has_controls:
            record.has_controls = has_controls
            self._changed.add(topic)

    def on_battery(self, topic, values, now):
        """A BatteryState as a dict: BATTERY_FIELDS, power_supply_status/health, location, serial_number."""
        self._silenced.pop(topic, None)
        record = self._record(topic, now)
        record.on_battery(dict(values), now, self.history_step_s)
        record.own_last = now

    def own_topics_dropped(self, topic):
        """The node no longer reads the battery's own topic and simulator state (a fleet host's messages
        bring it): those count from now on, not only once the own topic's last message is older than the
        stale time, and the simulator's extras (its time remaining first) are not shown frozen."""
        record = self.records.get(topic)
        if record is not None:
            record.own_last = None
            if record.sim:
                record.sim = {}
                self._changed.add(topic)

    def on_level_topic(self, topic, which, active, now):
        """battery_low (which='low') or battery_critical ('critical') of the battery ``topic``."""
        if topic in self._silenced:
            return
        setattr(self._record(topic, now), which + '_topic', bool(active))

    def on_sim_state(self, topic, sim, now):
        """The simulator's extras: charging_state, time_remaining_s, active_faults, cut_off, ...

        They come with every model update; the page hears of them with the next BatteryState
        unless the state, the faults or the cut-off changed."""
        if topic in self._silenced:
            return
        record = self._record(topic, now, changed=False)
        if any(record.sim.get(key) != sim.get(key) for key in ('charging_state', 'active_faults', 'cut_off')):
            self._changed.add(topic)
        record.sim = sim

    def on_fleet(self, topic, host, values, now):
        """One battery of a fleet host's states: names its host (the node that published it); its values
        count as a message while the battery's own topic is silent (not connected yet, gone, or none at
        all), unless they repeat the message already shown (the same header stamp: a host lists its
        robot's latest BatteryState, also after that robot's own topic went quiet). ``values``: the dict
        (with 'stamp') or a function that makes it (called only when needed)."""
        record = self.records.get(topic)
        if record is None or not record.own_topic_speaks(now):
            values = values() if callable(values) else dict(values)
            shown = record.stamp if record is not None and record.last_message is not None else \
                self._silenced.get(topic)
            if not _same_stamp(values.get('stamp'), shown):
                self._silenced.pop(topic, None)
                record = self._record(topic, now)
                record.on_battery(values, now, self.history_step_s)
        if record is not None and record.host != host:
            record.host = host
            self._changed.add(topic)

    def on_fleet_message(self, host_namespace, host, entries, now):
        """A BatteryFleetState from ``host`` (its publisher): [(robot name, values), ...] merged by name
        with what other hosts said (every host publishes its own robots on the one topic)."""
        for name, values in entries:
            self.on_fleet(fleet_battery_topic(host_namespace, name), host, values, now)

    def tick(self, now, views=True):
        """Trim histories, drop batteries silent for ~history_s, find stale changes.

        Returns (views of changed batteries, removed topics) since the last tick (no views,
        only the removed topics, when ``views`` is false: nobody is looking)."""
        for topic, record in list(self.records.items()):
            record.trim(now, self.history_s)
            last = record.last_message if record.last_message is not None else record.discovered
            if now - last > self.history_s:
                del self.records[topic]
                self._silenced[topic] = record.stamp
                self._changed.discard(topic)
                self._removed.add(topic)
                self._stale.discard(topic)
                continue
            stale = record.stale(now)
            if stale != (topic in self._stale):
                (self._stale.add if stale else self._stale.discard)(topic)
                self._changed.add(topic)
        changed = [self.records[topic].view(now) for topic in sorted(self._changed, key=natural_key)] if views else []
        removed = sorted(self._removed)
        self._changed.clear()
        self._removed.clear()
        return changed, removed

    def snapshot(self, now):
        """Every battery, in the natural order of its topic (robot2 before robot10)."""
        return [self.records[topic].view(now) for topic in sorted(self.records, key=natural_key)]

    def history(self, topic, now):
        """{'t': [...], 'percentage': [...], ...} over the last ~history_s; None for an unknown topic."""
        record = self.records.get(topic)
        if record is None:
            return None
        start = bisect.bisect_left([point[0] for point in record.history], now - self.history_s)
        points = list(record.history)[start:]
        series = {'t': [point[0] for point in points]}
        for index, field in enumerate(CHART_FIELDS, start=1):
            series[field] = [point[index] for point in points]
        return series
