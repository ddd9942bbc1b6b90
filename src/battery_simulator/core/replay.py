"""Replay a CSV load profile through the battery model, or a CC-CV charge (no ROS needed).

    battery_replay.py profile.csv [--preset NAME | --config FILE] [--soc 0.8] [-o out.csv]
    battery_replay.py --charge 1.5 [--soc 0.2] [--preset NAME | --config FILE] [-o out.csv]
    python3 -m battery_simulator.core.replay profile.csv ...

The profile has a header with ``time`` (s, never decreasing: equal times, as
cycler logs have, are a zero-length segment) and ``current`` (A, negative =
discharge, as in sensor_msgs/BatteryState) or ``power`` (W, same sign). Each
row's value is held until the next row's time (a config's
``profile_current_timing: since_previous_row``, which battery_fit writes for a
log that measured voltage and current at the same instant: since the previous
row's time). The output has one
row per profile row: the state at that time (time, voltage, current, soc 0..1,
temperature, status). A rest is one exact step, except for a learning gauge, which
looks at the voltage as it rests: then it is cut into ``--max-step`` pieces as a load is.

``--charge A`` charges at A amperes (the charger's constant current) from
``--soc`` (default 0) until the CV taper ends (Full), through the same
prediction as the service ``battery_simulator/predict``: one row per model
step, and on stderr how long it took.

``--soc`` is the truth (the output's ``soc``), as a node's initial_percentage:
a pack's fuel gauge starts where its config puts it (``initial_error``), in
``gauge_soc``. A charge ends at Full (the truth's end of the taper), whatever
a counter reads then; a learning gauge's rows go on, the pack held full on the
charger, to its own end of charge (its 100 % and ``end_of_charge``; at most
an hour). The time said is the charger's; stderr names the gauge's start and
end when they differ.
"""
import argparse
import contextlib
import csv
import math
import os
import sys
from dataclasses import replace

from battery_simulator.core.battery_states import Mode
from battery_simulator.core.command_line import OneLineParser
from battery_simulator.core.config_files import DEFAULT_PRESET, load_yaml, preset, preset_names
from battery_simulator.core.gauge import EVENT_KINDS
from battery_simulator.core.pack import make_model
from battery_simulator.core.parameter_rules import ParameterError
from battery_simulator.core.prediction import predict

#: soc is the truth; gauge_soc what the pack's fuel gauge reads (0-1); the cell voltages of the lowest
#: and highest series group (alike in a lumped pack); gauge_full_capacity_ah the capacity the gauge
#: believes (a learning gauge's learned one); gauge_event the corrections a learning gauge made since the
#: row before (ocv_rest, capacity_learned, end_of_charge; several joined by ';'; empty: none)
OUTPUT_COLUMNS = ('time', 'voltage', 'current', 'soc', 'temperature', 'status', 'cell_voltage_min',
                  'cell_voltage_max', 'gauge_soc', 'gauge_full_capacity_ah', 'gauge_event')
#: the shortest --max-step, s
MIN_STEP_S = 0.001
#: the most model steps one profile segment is cut into (the model is exact
#: for a held current; sub-steps only refine power loads and heating)
MAX_STEPS_PER_SEGMENT = 10000


class ProfileError(ValueError):
    """A profile file cannot be used; the message names the file and line."""


def read_profile(path):
    """[(time_s, kind, value)] from a profile CSV, kind 'current' or 'power'."""
    try:
        stream = open(path, newline='', encoding='utf-8-sig')  # -sig: spreadsheets write a BOM
    except OSError as error:
        raise ProfileError('%s: cannot read: %s' % (path, error.strerror)) from None
    try:
        with stream:
            return _read_rows(path, csv.reader(stream))
    except UnicodeDecodeError as error:
        raise ProfileError('%s: not a UTF-8 text CSV file (byte %d)' % (path, error.start)) from None
    except csv.Error as error:
        raise ProfileError('%s: not a CSV file: %s' % (path, error)) from None


def _read_rows(path, reader):
    """The (time_s, kind, value) rows after the header; ProfileError naming the line."""
    header = [name.strip().lower() for name in next(reader, [])]
    if 'time' not in header or not ({'current', 'power'} & set(header)):
        raise ProfileError('%s line 1: the header must name a "time" column and a "current" '
                           'or "power" column, got %s' % (path, ','.join(header) or 'nothing'))
    kind = 'current' if 'current' in header else 'power'
    time_column, value_column = header.index('time'), header.index(kind)
    rows = []
    for line, row in enumerate(reader, start=2):
        if not row or all(not cell.strip() for cell in row):
            continue
        try:
            time_s, value = float(row[time_column]), float(row[value_column])
        except (ValueError, IndexError):
            raise ProfileError('%s line %d: expected numbers in "time" and "%s", got %s'
                               % (path, line, kind, ','.join(row))) from None
        if not (math.isfinite(time_s) and math.isfinite(value)):
            raise ProfileError('%s line %d: values must be finite, got %s' % (path, line, ','.join(row)))
        if rows and time_s < rows[-1][0]:
            raise ProfileError('%s line %d: time %g s is before the previous row\'s %g s'
                               % (path, line, time_s, rows[-1][0]))
        rows.append((time_s, kind, value))
    if not rows:
        raise ProfileError('%s: no data rows after the header' % path)
    return rows


def replay(params, profile, state_of_charge=1.0, max_step_s=1.0, timing=None):
    """Yield an output row (see OUTPUT_COLUMNS) at each profile time.

    ``timing`` (default the config's ``profile_current_timing``): 'until_next_row' holds each row's value
    from its time until the next row's; 'since_previous_row' takes a row's value as the one that flowed since
    the previous row (a log that measured the voltage and the current at the same instant: a cycler's,
    BatteryState's), so each row's voltage answers its own current."""
    model = make_model(params, state_of_charge=state_of_charge, mode=Mode.IDLE)
    yield _row(profile[0][0], model)
    since_previous = (timing or params.profile_current_timing) == 'since_previous_row'
    for (start_s, kind, value), (end_s, next_kind, next_value) in zip(profile, profile[1:]):
        if since_previous:
            kind, value = next_kind, next_value
        if value == 0.0 and not (model.gauge is not None and model.gauge.watches_rests):
            steps = 1   # a rest is exact in one step (a learning gauge samples it: in max_step pieces)
        else:
            steps = min(max(1, int(math.ceil((end_s - start_s) / max_step_s))), MAX_STEPS_PER_SEGMENT)
        dt_s = (end_s - start_s) / steps
        for _ in range(steps):
            if kind == 'current':
                model.step(dt_s, current_a=value)
            else:
                model.step(dt_s, power_w=value)
        yield _row(end_s, model)


def _row(time_s, model):
    cells = model.cell_readings()[0]
    gauge = model.gauge
    full_capacity_ah = model.capacity_ah if gauge is None else gauge.capacity_ah
    return ('%g' % time_s, '%.4f' % model.voltage_v, '%.4f' % model.current_a,
            '%.5f' % model.state_of_charge, '%.2f' % model.temperature_c, model.status.name,
            '%.4f' % min(cells), '%.4f' % max(cells), '%.5f' % (model.gauge_reading()[0] / 100.0),
            '%.4f' % full_capacity_ah, gauge_events(model))


def gauge_events(model):
    """The corrections the model's gauge made since the last call, by name (EVENT_KINDS), joined by ';'."""
    if model.gauge is None:
        return ''
    names = []
    for event in model.gauge.take_events():
        if event.kind in EVENT_KINDS and event.kind not in names:
            names.append(event.kind)
    return ';'.join(names)


def charge(params, charge_current_a, state_of_charge=0.0):
    """A CC-CV charge at ``charge_current_a`` from ``state_of_charge`` to Full, through the prediction.

    Returns (rows as OUTPUT_COLUMNS, seconds to Full); ParameterError for a current the pack refuses.
    """
    try:
        params = replace(params, charge_current_a=charge_current_a)
    except ParameterError as error:
        raise ParameterError('--charge %g: %s' % (charge_current_a, error)) from None
    rows = []
    model = make_model(params, state_of_charge=state_of_charge, mode=Mode.IDLE)
    result = predict(model, (), observe=lambda time_s, m: rows.append(_row(time_s, m)), until_full=True)
    return rows, result.charge_time_s


def _number(text):
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError('%r is not a number' % text) from None


def _fraction(text):
    value = _number(text)
    if not 0.0 <= value <= 1.0:   # also NaN
        raise argparse.ArgumentTypeError('%s is not in [0, 1] (a fraction: 0.5 = half full)' % text)
    return value


def _current(text):
    value = _number(text)
    if not (math.isfinite(value) and value > 0.0):
        raise argparse.ArgumentTypeError('%s is not a current in amperes > 0' % text)
    return value


def _step(text):
    value = _number(text)
    if not (math.isfinite(value) and value >= MIN_STEP_S):
        raise argparse.ArgumentTypeError('%s is not a number of seconds >= %g' % (text, MIN_STEP_S))
    return value


def parse_arguments(argv):
    parser = OneLineParser(
        prog='battery_replay.py',
        description='Replay a CSV load profile through the battery model, or a CC-CV charge (--charge).')
    parser.add_argument('profile', nargs='?', help='CSV with time (s) and current (A) or power (W)')
    parser.add_argument('--charge', type=_current, metavar='A',
                        help='instead of a profile: a CC-CV charge at A amperes from --soc to Full')
    source = parser.add_mutually_exclusive_group()
    source.add_argument('--preset', help='battery preset (default %s)' % DEFAULT_PRESET)
    source.add_argument('--config', help='YAML file of battery parameters')
    parser.add_argument('--soc', type=_fraction,
                        help='initial state of charge (the truth; a gauge starts where its config puts it), '
                             '0..1 (default 1; with --charge 0): 0.2 = 20 %%')
    parser.add_argument('--max-step', type=_step, default=1.0,
                        help='longest model step, s (default 1, at least %g)' % MIN_STEP_S)
    parser.add_argument('-o', '--output', help='output CSV file (default: stdout)')
    parser.add_argument('--list-presets', action='store_true', help='list the presets and exit')
    args = parser.parse_args(argv)
    if args.charge is not None and args.profile is not None:
        parser.error('give a profile CSV or --charge, not both')
    if not args.list_presets and args.profile is None and args.charge is None:
        parser.error('the profile CSV (or --charge A) is required')
    if args.soc is None:
        args.soc = 0.0 if args.charge is not None else 1.0
    return args


def main(argv=None):
    args = parse_arguments(argv)
    try:
        _run(args)
    except KeyboardInterrupt:
        sys.stderr.write('battery_replay: interrupted\n')
        sys.exit(130)


def _run(args):
    if args.list_presets:
        print('\n'.join(preset_names()))
        return
    try:
        params = load_yaml(args.config) if args.config else preset(args.preset or DEFAULT_PRESET)
        if args.charge is not None:
            rows, charge_time_s = charge(params, args.charge, args.soc)
        else:
            rows = replay(params, read_profile(args.profile), state_of_charge=args.soc, max_step_s=args.max_step)
    except (ParameterError, ProfileError) as error:
        sys.exit('battery_replay: %s' % error)
    if args.output:
        _write_file(args.output, rows)
    else:
        try:
            _write(sys.stdout, rows)
            sys.stdout.flush()
        except BrokenPipeError:  # `... | head`: the reader has gone, which is fine
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
    if args.charge is not None:
        sys.stderr.write('battery_replay: %s charged at %g A from %g %% to Full in %.0f s (%s)%s\n' % (
            params.name, args.charge, 100.0 * args.soc, charge_time_s, _hours_minutes(charge_time_s),
            _gauge_view(rows)))


def _gauge_view(rows):
    """'; the gauge read A % then B %' when a charge's rows show a gauge that is not the truth, else ''."""
    soc, gauge = OUTPUT_COLUMNS.index('soc'), OUTPUT_COLUMNS.index('gauge_soc')
    if all(row[soc] == row[gauge] for row in rows):
        return ''
    return '; the gauge read %.1f %% then %.1f %%' % (100.0 * float(rows[0][gauge]), 100.0 * float(rows[-1][gauge]))


def _hours_minutes(seconds):
    minutes = int(round(seconds / 60.0))
    return '%d h %02d min' % divmod(minutes, 60)


def _write_file(path, rows):
    """All rows or nothing: written beside ``path`` and renamed when complete, so an error or
    Ctrl-C leaves no half-written file (and an older output as it was)."""
    partial = path + '.part'
    try:
        with open(partial, 'w', newline='', encoding='utf-8') as stream:
            _write(stream, rows)
        os.replace(partial, path)
    except OSError as error:
        sys.exit('battery_replay: cannot write %s: %s' % (path, error.strerror))
    finally:
        with contextlib.suppress(OSError):   # gone already once renamed
            os.remove(partial)


def _write(stream, rows):
    writer = csv.writer(stream, lineterminator='\n')
    writer.writerow(OUTPUT_COLUMNS)
    writer.writerows(rows)


if __name__ == '__main__':
    main()
