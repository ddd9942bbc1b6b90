"""battery_plot.py: voltage, current, percentage and temperature of a run, as a PNG.

    rosrun battery_simulator battery_plot.py run.csv -o run.png        # a battery_replay.py output
    rosrun battery_simulator battery_plot.py run.bag -o run.png        # a rosbag with battery_status

Status changes are marked on the time axis (dotted lines, labelled; marks
closer than a label's width share one label), and so are battery_low /
battery_critical events: from the bag's own topics when it recorded them, else
where what the robot read (the fuel gauge: battery_status's percentage, a
replay's gauge_soc) crosses ``--low`` / ``--critical`` (the publisher's
defaults 0.20 / 0.05), drawn as labelled lines on the charge plot; a bag's
``.../phase`` topic (patrol_and_dock's) is marked too. A replay's learning
gauge (Part 9) has its corrections drawn on the gauge's line (rest read,
capacity learned with its new value, end of charge) and the stretches it
held at 99 % shaded. The truth is drawn
beside the gauge when it differs (a replay's soc, a bag's
battery_simulator/state true_percentage), the series groups' cell voltages
as a min-max band, and with ``--config`` / ``--preset`` the cell cut-off and
charge voltages. Headless (matplotlib's Agg backend). A bad input gets one
line and exit 1.
"""
import argparse
import csv
import os
import sys
from collections import namedtuple

from battery_simulator.core.command_line import OneLineParser
from battery_simulator.core.config_files import load_yaml, preset
from battery_simulator.core.level_alarm import LevelAlarm
from battery_simulator.core.parameter_rules import ParameterError

#: one run: times (s from the start) and the four series, plus [(t, label)] marks
Run = namedtuple('Run', 'title time voltage current percentage temperature marks gauge cells truth gauge_events '
                 'gauge_capacity', defaults=(None, None, None, None, None))
# percentage: a replay's soc (the truth) or a bag's battery_status (what the robot read); gauge: a replay's
# gauge_soc (%), on ``time``; cells: (min, max) cell voltages on ``time``; truth: a bag's
# battery_simulator/state ([times], [true_percentage]) on its own times; gauge_events: a replay's learning gauge's
# corrections [(t, kind)] (ocv_rest, capacity_learned, end_of_charge); gauge_capacity: its gauge_full_capacity_ah
#: how each of a learning gauge's corrections is drawn on the charge plot: (marker, colour, legend text)
GAUGE_EVENT_STYLE = {'ocv_rest': ('v', 'tab:blue', 'rest read (OCV)'),
                     'capacity_learned': ('*', 'tab:red', 'capacity learned'),
                     'end_of_charge': ('s', 'black', 'end of charge (99 % -> 100 %)')}
#: marks closer than this fraction of the run share one label ("FULL, UNDOCK": the same moment)
SAME_MOMENT = 0.002
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


def level_marks(times, fractions, low=LOW, critical=CRITICAL):
    """[(t, 'low' / 'low cleared' / ...)] where ``fractions`` (what the robot read) cross the thresholds,
    with the publisher's hysteresis."""
    alarms = (('low', LevelAlarm(low, HYSTERESIS)), ('critical', LevelAlarm(critical, HYSTERESIS)))
    marks = []
    for t, fraction in zip(times, fractions):
        for name, alarm in alarms:
            if alarm.update(fraction):
                marks.append((t, name if alarm.active else name + ' cleared'))
    return marks


def read_replay_csv(path, low=LOW, critical=CRITICAL):
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
    gauge = cells = events = capacity = None
    try:
        if 'gauge_soc' in rows[0]:   # Part 5's columns (a CSV of an older replay has none)
            gauge = [100.0 * float(r['gauge_soc']) for r in rows]
            cells = ([float(r['cell_voltage_min']) for r in rows], [float(r['cell_voltage_max']) for r in rows])
        if 'gauge_event' in rows[0]:   # Part 9's
            events = [(t, kind) for t, r in zip(time, rows) for kind in (r['gauge_event'] or '').split(';')
                      if kind in GAUGE_EVENT_STYLE]
            capacity = [float(r['gauge_full_capacity_ah']) for r in rows]
    except (TypeError, ValueError, KeyError) as error:
        raise PlotError('%s: a value is not a number (%s)' % (path, error)) from None
    read = [g / 100.0 for g in gauge] if gauge is not None else soc   # low/critical: what the robot read
    marks = status_marks(time, [r['status'] for r in rows]) + level_marks(time, read, low, critical)
    return Run(str(path), time, percentage=[100.0 * s for s in soc], marks=sorted(marks), gauge=gauge, cells=cells,
               gauge_events=events or None, gauge_capacity=capacity, **series)


def read_rosbag(path, topic=None, low=LOW, critical=CRITICAL):
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
        state = namespace + 'battery_simulator/state'
        messages, alarm_marks, active, truth = [], [], {}, []
        for name, msg, stamp in bag.read_messages(topics=[topic, state] + list(events) + phases):
            if name == topic:
                messages.append(msg)
            elif name == state:
                truth.append((msg.battery.header.stamp.to_sec(), msg.true_percentage))
            elif name in phases:
                alarm_marks.append((stamp.to_sec(), msg.data))
            elif msg.data != active.setdefault(name, False):   # a change, not the latched initial false
                active[name] = msg.data
                alarm_marks.append((stamp.to_sec(), events[name] + ('' if msg.data else ' cleared')))
    if not messages:
        raise PlotError('%s: no messages on %s' % (path, topic))
    start = messages[0].header.stamp.to_sec()
    time = [m.header.stamp.to_sec() - start for m in messages]
    marks = status_marks(time, [SUPPLY_STATUS.get(m.power_supply_status, '?') for m in messages])
    marks += [(max(0.0, t - start), label) for t, label in alarm_marks]
    if not active:   # no battery_low / battery_critical recorded (phases are not events): from what was read
        marks += level_marks(time, [m.percentage for m in messages], low, critical)
    cells = None
    if all(m.cell_voltage for m in messages):
        cells = ([min(m.cell_voltage) for m in messages], [max(m.cell_voltage) for m in messages])
    truth = ([max(0.0, t - start) for t, _ in truth], [p for _, p in truth]) if truth else None
    return Run('%s (%s)' % (os.path.basename(str(path)), topic), time, voltage=[m.voltage for m in messages],
               current=[m.current for m in messages], percentage=[100.0 * m.percentage for m in messages],
               temperature=[m.temperature for m in messages], marks=sorted(marks), cells=cells, truth=truth)


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


def plot(run, output, low=LOW, critical=CRITICAL, cell_limits=None):
    """The PNG; ``cell_limits``: (cut-off, charge voltage) per cell to draw beside the cells, or None."""
    import matplotlib
    matplotlib.use('Agg')
    from matplotlib import pyplot

    minutes = run.time[-1] > 600
    scale, unit = (1 / 60.0, 'min') if minutes else (1.0, 's')
    time = [t * scale for t in run.time]
    panels = [('voltage (V)', run.voltage, 'tab:blue')]
    if run.cells is not None:
        panels.append(('cell voltage (V)', None, None))
    panels += [('current (A)', run.current, 'tab:red'), ('charge (%)', run.percentage, 'tab:green'),
               ('temperature (°C)', run.temperature, 'tab:orange')]
    figure, axes = pyplot.subplots(len(panels) + 1, 1, sharex=True, figsize=(10, 2.0 + 2.0 * len(panels)),
                                   gridspec_kw={'height_ratios': [0.9] + [2.0] * len(panels)})
    strip, axes = axes[0], list(axes[1:])
    by_name = {}
    for axis, (label, values, colour) in zip(axes, panels):
        if values is not None:
            axis.plot(time, values, color=colour, linewidth=1.2)
        axis.set_ylabel(label)
        axis.grid(alpha=0.3)
        for t, _ in run.marks:
            axis.axvline(t * scale, color='grey', linestyle=':', linewidth=0.8)
        by_name[label] = axis
    charge = by_name['charge (%)']
    if run.gauge is not None and any(abs(g - p) > 0.05 for g, p in zip(run.gauge, run.percentage)):
        charge.plot(time, run.gauge, color='tab:purple', linewidth=1.0, linestyle='--', label='fuel gauge (read)')
        charge.lines[0].set_label('true charge')
        charge.legend(loc='lower left', fontsize=8)
    if run.gauge_events and run.gauge is not None:
        _draw_gauge_events(charge, run, scale)
    elif run.truth is not None:   # a bag: battery_status is the gauge, battery_simulator/state the truth
        read = charge.lines[0]
        read.set(label='what the robot read (battery_status)', linestyle='--', color='tab:purple')
        charge.plot([t * scale for t in run.truth[0]], run.truth[1], color='tab:green', linewidth=1.0,
                    label='the truth (battery_simulator/state)')
        charge.legend(loc='lower left', fontsize=8)
    for level, name in ((low, 'low'), (critical, 'critical')):   # where what the robot read raises the events
        charge.axhline(100.0 * level, color='darkred', linewidth=0.7, linestyle='-.')
        charge.annotate('%s %g %%' % (name, 100.0 * level), xy=(1.0, 100.0 * level),
                        xycoords=('axes fraction', 'data'), xytext=(-4, 1), textcoords='offset points', ha='right',
                        va='bottom', fontsize=7, color='darkred')
    charge.set_ylim(-2, 102)
    if run.cells is not None:
        cells = by_name['cell voltage (V)']
        cells.fill_between(time, run.cells[0], run.cells[1], color='tab:cyan', alpha=0.4, linewidth=0)
        cells.plot(time, run.cells[0], color='teal', linewidth=0.8, label='lowest cell group')
        cells.plot(time, run.cells[1], color='tab:cyan', linewidth=0.8, label='highest cell group')
        for volts, name in zip(cell_limits or (), ('cut-off', 'charge voltage')):
            cells.axhline(volts, color='darkred', linewidth=0.7, linestyle='-.')
            cells.annotate('cell %s %.2f V' % (name, volts), xy=(1.0, volts), xycoords=('axes fraction', 'data'),
                           xytext=(-4, 1 if name == 'cut-off' else -1), textcoords='offset points', ha='right',
                           va='bottom' if name == 'cut-off' else 'top', fontsize=7, color='darkred')
        cells.legend(loc='lower left', fontsize=8)
    axes[-1].set_xlabel('time (%s)' % unit)
    figure.suptitle(run.title, fontsize=10)
    _label_strip(figure, strip, run.marks, scale, axes[0])
    figure.tight_layout()
    try:
        figure.savefig(output, dpi=110)
    except OSError as error:
        raise PlotError('cannot write %s: %s' % (output, error.strerror)) from None
    finally:
        pyplot.close(figure)


def _draw_gauge_events(charge, run, scale):
    """A learning gauge's corrections on the charge plot, each where the gauge was after it (a rest read, a
    learned capacity with its new value, the end of charge), and the stretches it held at 99 % shaded."""
    at = {t: index for index, t in enumerate(run.time)}
    for kind, (marker, colour, text) in GAUGE_EVENT_STYLE.items():
        times = [t for t, k in run.gauge_events if k == kind]
        if not times:
            continue
        charge.scatter([t * scale for t in times], [run.gauge[at[t]] for t in times], marker=marker, color=colour,
                       s=60 if marker == '*' else 22, zorder=5, label=text)
        if kind == 'capacity_learned' and run.gauge_capacity is not None:
            for t in times:
                charge.annotate('%.3f Ah' % run.gauge_capacity[at[t]], xy=(t * scale, run.gauge[at[t]]),
                                xytext=(4, -10), textcoords='offset points', fontsize=7, color=colour)
    start, shaded = None, False
    for index, holding in enumerate([abs(g - 99.0) < 0.01 for g in run.gauge] + [False]):
        if holding and start is None:
            start = index
        elif not holding and start is not None:
            if index - start > 1:
                charge.axvspan(run.time[start] * scale, run.time[index - 1] * scale, color='gold', alpha=0.35,
                               linewidth=0, label=None if shaded else 'held at 99 %')
                shaded = True
            start = None
    charge.legend(loc='lower left', fontsize=7, ncol=2)


def _label_strip(figure, strip, marks, scale, reference):
    """The marks' labels in a strip above the plots, each in the lowest lane where it overlaps none
    (measured as drawn), with a tick down to its moment: labels never print over one another."""
    strip.set_xlim(reference.get_xlim())
    strip.axis('off')
    texts = []
    if marks:
        span = marks[-1][0] - marks[0][0] or 1.0
        for t, text in merged_marks(marks, span, SAME_MOMENT):
            event = 'low' in text or 'critical' in text
            texts.append((t * scale, strip.text(t * scale, 0.0, text, fontsize=7, ha='center', va='bottom',
                                                color='darkred' if event else 'dimgrey')))
    figure.tight_layout()
    renderer = figure.canvas.get_renderer()
    lanes = []   # per lane, the right edge (px) of its last label
    for x, text in texts:
        box = text.get_window_extent(renderer)
        lane = next((k for k, right in enumerate(lanes) if box.x0 > right + 3), len(lanes))
        if lane == len(lanes):
            lanes.append(0.0)
        lanes[lane] = box.x1
        text.set_y(lane)
        strip.plot([x, x], [lane - 0.15, lane], color='grey', linewidth=0.6)
    strip.set_ylim(-0.3, max(len(lanes), 3))
    return [text for _, text in texts]


def main(argv=None):
    parser = OneLineParser(prog='battery_plot.py', description='Plot a battery run into a PNG.')
    parser.add_argument('input', help='a battery_replay.py output CSV, or a rosbag with a BatteryState topic')
    parser.add_argument('-o', '--output', default='battery.png', help='PNG to write (default battery.png)')
    parser.add_argument('--topic', help='BatteryState topic in the bag (default: the one ending in battery_status)')
    parser.add_argument('--title', help='the figure title (default: the file name)')
    parser.add_argument('--low', type=_fraction, default=LOW,
                        help='the low level, a fraction (default %g, battery_state_pub\'s; demo.launch: 0.25)' % LOW)
    parser.add_argument('--critical', type=_fraction, default=CRITICAL,
                        help='the critical level, a fraction (default %g)' % CRITICAL)
    pack = parser.add_mutually_exclusive_group()
    pack.add_argument('--config', help='the battery config YAML: draw its cell cut-off and charge voltages')
    pack.add_argument('--preset', help='a battery preset: draw its cell cut-off and charge voltages')
    args = parser.parse_args(argv)
    try:
        cell_limits = _cell_limits(args.config, args.preset)
        with open(args.input, 'rb') as stream:
            is_bag = stream.read(13) == b'#ROSBAG V2.0\n'
        run = read_rosbag(args.input, args.topic, args.low, args.critical) if is_bag \
            else read_replay_csv(args.input, args.low, args.critical)
        if args.title:
            run = run._replace(title=args.title)
        plot(run, args.output, args.low, args.critical, cell_limits)
    except OSError as error:
        sys.exit('battery_plot: %s: cannot read: %s' % (args.input, error.strerror))
    except (PlotError, ParameterError) as error:
        sys.exit('battery_plot: %s' % error)
    print('wrote %s (%d points, %d marks)' % (args.output, len(run.time), len(run.marks)))


def _fraction(text):
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError('%r is not a number' % text) from None
    if not 0.0 <= value <= 1.0:   # also NaN
        raise argparse.ArgumentTypeError('%s is not a fraction in [0, 1] (0.25 = 25 %%)' % text)
    return value


def _cell_limits(config, preset_name):
    """(cell cut-off, cell charge voltage) of the config or preset given, or None."""
    if config is None and preset_name is None:
        return None
    params = load_yaml(config) if config else preset(preset_name)
    return params.cell_cutoff_voltage_v, params.cell_charge_voltage_v
