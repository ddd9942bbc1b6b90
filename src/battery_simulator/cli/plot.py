"""battery_plot.py: voltage, current, percentage and temperature of a run, as a PNG.

    rosrun battery_simulator battery_plot.py run.csv -o run.png        # a battery_replay.py output
    rosrun battery_simulator battery_plot.py run.bag -o run.png        # a rosbag with battery_status

Status changes are marked on the time axis (dotted lines, labelled), and so
are battery_low / battery_critical events: from the bag's own topics when it
recorded them, else from the level and the default thresholds; a bag's
``.../phase`` topic (patrol_and_dock's) is marked too. Headless
(matplotlib's Agg backend). A bad input gets one line and exit 1.
"""
import argparse
import csv
import os
import sys
from collections import namedtuple

from battery_simulator.core.level_alarm import LevelAlarm

#: one run: times (s from the start) and the four series, plus [(t, label)] marks
Run = namedtuple('Run', 'title time voltage current percentage temperature marks gauge cells',
                 defaults=(None, None))   # gauge: what the fuel gauge read (%); cells: (min, max) cell voltages
SUPPLY_STATUS = {0: 'UNKNOWN', 1: 'CHARGING', 2: 'DISCHARGING', 3: 'NOT_CHARGING', 4: 'FULL'}
LOW, CRITICAL, HYSTERESIS = 0.20, 0.05, 0.05   # the publisher's defaults


class PlotError(ValueError):
    """The input cannot be plotted; the message names it."""


def status_marks(times, statuses):
    """[(t, status)] wherever the status changes (and at the start)."""
    marks = []
    for t, status in zip(times, statuses):
        if not marks or status != marks[-1][1]:
            marks.append((t, status))
    return marks


def level_marks(times, fractions):
    """[(t, 'low' / 'low cleared' / ...)] from the level, with the publisher's default thresholds."""
    alarms = (('low', LevelAlarm(LOW, HYSTERESIS)), ('critical', LevelAlarm(CRITICAL, HYSTERESIS)))
    marks = []
    for t, fraction in zip(times, fractions):
        for name, alarm in alarms:
            if alarm.update(fraction):
                marks.append((t, name if alarm.active else name + ' cleared'))
    return marks


def read_replay_csv(path):
    try:
        with open(path, newline='', encoding='utf-8-sig') as stream:
            rows = list(csv.DictReader(stream))
    except OSError as error:
        raise PlotError('%s: cannot read: %s' % (path, error.strerror)) from None
    except (UnicodeDecodeError, csv.Error) as error:
        raise PlotError('%s: not a replay CSV (%s)' % (path, error)) from None
    needed = ('time', 'voltage', 'current', 'soc', 'temperature', 'status')
    if not rows or any(name not in rows[0] for name in needed):
        raise PlotError('%s: not a battery_replay.py output (columns %s)' % (path, ', '.join(needed)))
    try:
        time = [float(r['time']) for r in rows]
        soc = [float(r['soc']) for r in rows]
        series = dict(voltage=[float(r['voltage']) for r in rows], current=[float(r['current']) for r in rows],
                      temperature=[float(r['temperature']) for r in rows])
    except (TypeError, ValueError) as error:
        raise PlotError('%s: a value is not a number (%s)' % (path, error)) from None
    start = time[0]
    time = [t - start for t in time]
    marks = status_marks(time, [r['status'] for r in rows]) + level_marks(time, soc)
    gauge = cells = None
    try:
        if 'gauge_soc' in rows[0]:   # Part 5's columns (a CSV of an older replay has none)
            gauge = [100.0 * float(r['gauge_soc']) for r in rows]
            cells = ([float(r['cell_voltage_min']) for r in rows], [float(r['cell_voltage_max']) for r in rows])
    except (TypeError, ValueError, KeyError) as error:
        raise PlotError('%s: a value is not a number (%s)' % (path, error)) from None
    return Run(str(path), time, percentage=[100.0 * s for s in soc], marks=sorted(marks), gauge=gauge, cells=cells,
               **series)


def read_rosbag(path, topic=None):
    import rosbag   # ROS: only for bags
    try:
        bag = rosbag.Bag(str(path))
    except (OSError, rosbag.ROSBagException) as error:
        raise PlotError('%s: not a readable rosbag (%s)' % (path, error)) from None
    with bag:
        types = bag.get_type_and_topic_info().topics
        states = [t for t, info in types.items() if info.msg_type == 'sensor_msgs/BatteryState']
        if topic is None:
            topic = next((t for t in states if t.endswith('battery_status')), states[0] if states else None)
        if topic is None or topic not in states:
            raise PlotError('%s: no sensor_msgs/BatteryState topic%s (has: %s)'
                            % (path, ' %s' % topic if topic else '', ', '.join(sorted(types)) or 'nothing'))
        namespace = topic[:-len('battery_status')] if topic.endswith('battery_status') else ''
        events = {namespace + 'battery_low': 'low', namespace + 'battery_critical': 'critical'}
        phases = [t for t, info in types.items() if t.endswith('/phase') and info.msg_type == 'std_msgs/String']
        messages, alarm_marks, active = [], [], {}
        for name, msg, stamp in bag.read_messages(topics=[topic] + list(events) + phases):
            if name == topic:
                messages.append(msg)
            elif name in phases:
                alarm_marks.append((stamp.to_sec(), msg.data))
            elif msg.data != active.get(name, False):   # a change, not the latched initial false
                active[name] = msg.data
                alarm_marks.append((stamp.to_sec(), events[name] + ('' if msg.data else ' cleared')))
    if not messages:
        raise PlotError('%s: no messages on %s' % (path, topic))
    start = messages[0].header.stamp.to_sec()
    time = [m.header.stamp.to_sec() - start for m in messages]
    marks = status_marks(time, [SUPPLY_STATUS.get(m.power_supply_status, '?') for m in messages])
    if alarm_marks:
        marks += [(max(0.0, t - start), label) for t, label in alarm_marks]
    else:
        marks += level_marks(time, [m.percentage for m in messages])
    return Run('%s (%s)' % (os.path.basename(str(path)), topic), time, voltage=[m.voltage for m in messages],
               current=[m.current for m in messages], percentage=[100.0 * m.percentage for m in messages],
               temperature=[m.temperature for m in messages], marks=sorted(marks))


def merged_marks(marks, span, fraction=0.02):
    """Marks closer together than ``fraction`` of ``span`` as one label ("FULL, UNDOCK"), so none print over another."""
    merged = []
    for t, text in sorted(marks):
        if merged and t - merged[-1][0] < fraction * span:
            if text not in merged[-1][1].split(', '):   # a status and a phase may say the same (CHARGING)
                merged[-1] = (merged[-1][0], merged[-1][1] + ', ' + text)
        else:
            merged.append((t, text))
    return merged


def plot(run, output):
    import matplotlib
    matplotlib.use('Agg')
    from matplotlib import pyplot

    minutes = run.time[-1] > 600
    scale, unit = (1 / 60.0, 'min') if minutes else (1.0, 's')
    time = [t * scale for t in run.time]
    figure, axes = pyplot.subplots(4, 1, sharex=True, figsize=(10, 9))
    for axis, values, label, colour in zip(
            axes, (run.voltage, run.current, run.percentage, run.temperature),
            ('voltage (V)', 'current (A)', 'charge (%)', 'temperature (°C)'),
            ('tab:blue', 'tab:red', 'tab:green', 'tab:orange')):
        axis.plot(time, values, color=colour, linewidth=1.2)
        axis.set_ylabel(label)
        axis.grid(alpha=0.3)
        for t, _ in run.marks:
            axis.axvline(t * scale, color='grey', linestyle=':', linewidth=0.8)
    if run.gauge is not None and any(abs(g - p) > 0.05 for g, p in zip(run.gauge, run.percentage)):
        axes[2].plot(time, run.gauge, color='tab:purple', linewidth=1.0, linestyle='--', label='fuel gauge')
        axes[2].lines[0].set_label('true charge')
        axes[2].legend(loc='best', fontsize=8)
    if run.cells is not None and any(high - low > 1e-4 for low, high in zip(*run.cells)):
        cell_axis = axes[0].twinx()   # the spread of the series groups, per cell
        cell_axis.fill_between(time, run.cells[0], run.cells[1], color='tab:cyan', alpha=0.35, linewidth=0)
        cell_axis.set_ylabel('cell min-max (V)', fontsize=8)
    axes[2].set_ylim(-2, 102)
    top = axes[0]
    labels = merged_marks(run.marks, run.time[-1] - run.time[0] if len(run.time) > 1 else 1.0)
    for index, (t, text) in enumerate(labels):   # inside the top plot, alternating ends so neighbours overlap less
        event = 'low' in text or 'critical' in text
        top.annotate(' %s ' % text, xy=(t * scale, 0.03 if index % 2 else 0.97), xycoords=('data', 'axes fraction'),
                     rotation=90, fontsize=7, va='bottom' if index % 2 else 'top', ha='right',
                     color='darkred' if event else 'dimgrey')
    axes[-1].set_xlabel('time (%s)' % unit)
    figure.suptitle(run.title, fontsize=10)
    figure.tight_layout()
    try:
        figure.savefig(output, dpi=110)
    except OSError as error:
        raise PlotError('cannot write %s: %s' % (output, error.strerror)) from None
    finally:
        pyplot.close(figure)


def main(argv=None):
    parser = argparse.ArgumentParser(prog='battery_plot.py', description='Plot a battery run into a PNG.')
    parser.add_argument('input', help='a battery_replay.py output CSV, or a rosbag with a BatteryState topic')
    parser.add_argument('-o', '--output', default='battery.png', help='PNG to write (default battery.png)')
    parser.add_argument('--topic', help='BatteryState topic in the bag (default: the one ending in battery_status)')
    parser.add_argument('--title', help='the figure title (default: the file name)')
    args = parser.parse_args(argv)
    try:
        with open(args.input, 'rb') as stream:
            is_bag = stream.read(13) == b'#ROSBAG V2.0\n'
        run = read_rosbag(args.input, args.topic) if is_bag else read_replay_csv(args.input)
        if args.title:
            run = run._replace(title=args.title)
        plot(run, args.output)
    except OSError as error:
        sys.exit('battery_plot: %s: cannot read: %s' % (args.input, error.strerror))
    except PlotError as error:
        sys.exit('battery_plot: %s' % error)
    print('wrote %s (%d points, %d marks)' % (args.output, len(run.time), len(run.marks)))
