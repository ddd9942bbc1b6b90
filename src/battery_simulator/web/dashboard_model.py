"""What the dashboard knows about every battery, without ROS (no rospy, no messages).

The node hands in plain values (a BatteryState as a dict of numbers, a Bool, a
few fields of the simulator's state) with the wall time they arrived; the web
app reads formatted records and histories out. Every rule the page shows lives
here or in the two modules beside it: web/topic_discovery.py (which topics are batteries),
web/dashboard_texts.py (the text of each field); here stale, low / critical, time remaining.
"""
import bisect
import collections

from battery_simulator.core import status_codes
from battery_simulator.core.node_settings import PUBLISHER_SETTINGS
from battery_simulator.core.parameter_rules import is_number
from battery_simulator.web.dashboard_texts import (SIM_CHARGING_STATE, SUPPLY_HEALTH, SUPPLY_STATUS, duration_text,
                                                   in_range, json_number, natural_key, number_text, percentage_text)
from battery_simulator.web.topic_discovery import fleet_battery_topic

STALE_MIN_S = 3.0        # stale after no message for max(this, STALE_PERIODS periods)
STALE_PERIODS = 3
#: without a battery_low / battery_critical topic: battery_state_pub's default thresholds
LOW_FRACTION, CRITICAL_FRACTION = (next(s.default for s in PUBLISHER_SETTINGS if s.name == name)
                                   for name in ('low_percentage', 'critical_percentage'))
HISTORY_POINTS = 1200    # at most this many chart points per battery over ~history_s
PERIOD_SAMPLES = 8       # arrival intervals the period estimate takes the median of
#: the numbers a BatteryState gives (pack units: V, A, degC, Ah; percentage 0..1)
BATTERY_FIELDS = ('percentage', 'voltage', 'current', 'temperature', 'charge', 'capacity', 'design_capacity')
CHART_FIELDS = ('percentage', 'voltage', 'current', 'temperature')
#: the faults a simulated battery knows (the page gets them in its snapshot)
FAULTS = tuple(sorted(status_codes.FAULTS))


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



def _same_stamp(stamp, shown):
    """A known header stamp (not 0: a publisher that leaves it unset) equal to the one shown."""
    return is_number(stamp) and stamp > 0.0 and stamp == shown

# -- one battery -------------------------------------------------------------------

class DashboardBattery:
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
            record = self.records[topic] = DashboardBattery(topic, now)
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
