"""battery_fit: your robot's battery config from its own logs (contract Part 8).

    rosrun battery_simulator battery_fit.py LOG [LOG ...] -o my_robot.yaml [--plot fit.png]
    tools/ros2.sh battery_fit LOG [LOG ...] -o my_robot.yaml            (ROS 2: battery_fit)

LOG: a ROS 1 bag, a ROS 2 bag (MCAP or sqlite3: its directory or its file) or a CSV with time, voltage,
current and optionally temperature, percentage, linear_x, angular_z. Several logs of one robot are fitted
together. The report goes to stdout; a progress bar to a terminal's stderr. A log that cannot be fitted:
one line, exit status 1 (2 for a bad argument); no config is written then.
"""
import argparse
import os
import sys
import time

try:   # numpy and the model load for half a second: a Ctrl-C then is an interrupt too, not a traceback
    from battery_simulator.core.command_line import OneLineParser
    from battery_simulator.core.fit import FitError
    from battery_simulator.core.fit.config_writer import WRITTEN_BY, config_text, write_config
    from battery_simulator.core.fit.conventions import prepare, split_at_gaps
    from battery_simulator.core.fit.fitting import DEFAULT_HOLDOUT, fit
    from battery_simulator.core.fit.log_reader import read_log
    from battery_simulator.core.fit.report import figures, report_text, write_profile
    from battery_simulator.core.config_files import preset, preset_names
    from battery_simulator.core.parameter_rules import MAX_CELLS, ParameterError
except KeyboardInterrupt:
    sys.stderr.write('\nbattery_fit: interrupted (no config written)\n')
    sys.exit(130)

PROG = 'battery_fit'
DEFAULT_CHEMISTRY = 'lg_hg2_cell'
#: --chemistry's short names; without --chemistry these are tried and the logs decide
CHEMISTRIES = {'lg_hg2': 'lg_hg2_cell', 'li-ion': 'lg_hg2_cell', 'nmc': 'lg_hg2_cell', 'lfp': 'a123_lfp_cell'}
#: the plot's metadata says battery_fit wrote it (a later run may write over it, over no other file); the key per
#: format matplotlib writes metadata in (the others: an existing file is never written over)
PLOT_MARK = 'battery_fit (battery_simulator)'
PLOT_METADATA_KEY = {'png': 'Software', 'pdf': 'Creator', 'svg': 'Creator', 'eps': 'Creator', 'ps': 'Creator'}
#: how much of an existing plot is searched for PLOT_MARK (a PDF has it at its end)
PLOT_MARK_SEARCH_BYTES = 32 * 1024 * 1024
DETECTED = ('lg_hg2_cell', 'a123_lfp_cell', 'bmw_i3_60ah_cell')
BAR_WIDTH = 30
#: a fit worse than this (per cell, on the fitted part) is refused: the logs are not what the model is
MAX_RMSE_PER_CELL_V = 0.2


def _cells(text):
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError('%r is not a whole number' % text) from None
    if not 1 <= value <= MAX_CELLS:
        raise argparse.ArgumentTypeError('%d is not in [1, %d]' % (value, MAX_CELLS))
    return value


def _holdout(text):
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError('%r is not a number' % text) from None
    if not 0.0 <= value <= 0.75:   # also NaN
        raise argparse.ArgumentTypeError('%s is not in [0, 0.75] (the fraction of each log held out)' % text)
    return value


def parse_arguments(argv):
    parser = OneLineParser(prog=PROG, description='Fit a battery config to recorded logs of your robot.')
    parser.add_argument('logs', nargs='+', metavar='LOG', help='ROS 1 bag, ROS 2 bag (MCAP / sqlite3) or CSV')
    parser.add_argument('-o', '--output', required=True, metavar='CONFIG.yaml', help='the config to write')
    parser.add_argument('--cells-series', type=_cells, help='cells in series (default: from the voltage range)')
    parser.add_argument('--chemistry', help='li-ion, lfp or a preset whose cell shape is fitted (default: found '
                        'from the logs among %s)' % ', '.join(DETECTED))
    parser.add_argument('--battery-topic', help='the sensor_msgs/BatteryState topic (default: found by type)')
    parser.add_argument('--motion-topic', help='the cmd_vel (Twist, TwistStamped) or Odometry topic')
    parser.add_argument('--holdout', type=_holdout, default=DEFAULT_HOLDOUT,
                        help='fraction of each log held out at its end (default %g)' % DEFAULT_HOLDOUT)
    parser.add_argument('--plot', metavar='PNG', help='the logs\' voltage against the model\'s, with residuals')
    parser.add_argument('--profiles', metavar='DIR', help='write each log\'s current as a battery_replay profile')
    args = parser.parse_args(argv)
    if args.chemistry is not None and args.chemistry not in preset_names():
        args.chemistry = args.chemistry.lower()   # LFP, Li-ion
    args.chemistry = CHEMISTRIES.get(args.chemistry, args.chemistry)
    if args.chemistry is not None and args.chemistry not in preset_names():
        parser.error('argument --chemistry: %r is neither %s nor a preset (one of %s)' % (
            args.chemistry, ', '.join(sorted(CHEMISTRIES)), ', '.join(preset_names())))
    if os.path.isdir(args.output):
        parser.error('argument -o: %s is a directory (give a file name for the config)' % args.output)
    problem = output_problem(args.output, args.logs) or _directory_problem(args.output)
    if problem:
        parser.error('argument -o: %s' % problem)
    problem = _writable_problem(os.path.dirname(os.path.abspath(args.output)))
    if problem:
        parser.error('argument -o: %s' % problem)
    if args.profiles is not None:
        problem = profiles_problem(args.profiles, args.output, args.logs)
        if problem:
            parser.error('argument --profiles: %s' % problem)
    if args.plot is not None:
        problem = plot_problem(args.plot, args.output, args.logs)
        if problem:
            parser.error('argument --plot: %s' % problem)
    return args


def _writable_problem(directory):
    """Why no file can be made in ``directory`` (tried with a file of its own name, removed again), or None."""
    import tempfile
    try:
        handle, probe = tempfile.mkstemp(prefix='.battery_fit_probe_', dir=directory)
    except OSError as error:
        return 'cannot write into %s: %s' % (directory, error.strerror)
    os.close(handle)
    os.remove(probe)
    return None


def profiles_problem(directory, output, logs):
    """Why --profiles DIR cannot be used (checked before the fit), or None: a file, or a directory that cannot be
    made or written into."""
    if os.path.exists(directory) and not os.path.isdir(directory):
        return '%s exists and is not a directory' % directory
    parent = os.path.dirname(os.path.abspath(directory))
    if not os.path.isdir(directory):
        if not os.path.isdir(parent):
            return 'no such directory %s' % parent
        return _writable_problem(parent)
    return _writable_problem(directory)


def _directory_problem(path):
    directory = os.path.dirname(os.path.abspath(path))
    return None if os.path.isdir(directory) else 'no such directory %s' % directory


def plot_problem(path, output, logs):
    """Why the plot cannot go to ``path`` (checked before the fit, which may take minutes), or None: a
    directory, a missing directory, one of the logs, the config, a file battery_fit did not write (PLOT_MARK), a
    format matplotlib does not write."""
    if os.path.isdir(path):
        return '%s is a directory (give a file name for the plot)' % path
    problem = _directory_problem(path)
    if problem:
        return problem
    if os.path.abspath(path) == os.path.abspath(output):
        return '%s is the config (-o): give the plot another file name' % path
    for log in logs:
        if os.path.exists(path) and os.path.exists(log) and os.path.samefile(path, log):
            return '%s is one of the logs (give another file name for the plot)' % path
    if os.path.exists(path) and not _plot_battery_fit_wrote(path):
        return ('%s exists and is not a plot battery_fit wrote: it is left alone (remove it, or give another file '
                'name)' % path)
    try:
        from matplotlib.backend_bases import FigureCanvasBase
    except ImportError:
        return 'needs matplotlib (python3-matplotlib)'
    formats = FigureCanvasBase.get_supported_filetypes()
    extension = _extension(path)
    if extension and extension not in formats:
        return '%s: matplotlib writes no .%s (png, or one of %s)' % (path, extension, ', '.join(sorted(formats)))
    return None


def _extension(path):
    """The file name's extension, lower case, without the dot ('' for none)."""
    return os.path.splitext(path)[1][1:].lower()


def _plot_battery_fit_wrote(path):
    try:
        with open(path, 'rb') as stream:
            return PLOT_MARK.encode() in stream.read(PLOT_MARK_SEARCH_BYTES)
    except OSError:
        return False


def output_problem(output, logs):
    """Why ``output`` must not be written (a user's file is never written over), or None: it is one of the
    logs, or it exists and is not a config battery_fit wrote (its first line says so)."""
    if not os.path.exists(output):
        return None
    for log in logs:
        if os.path.exists(log) and os.path.samefile(output, log):
            return '%s is one of the logs (give another file name for the config)' % output
    try:
        with open(output, encoding='utf-8', errors='replace') as stream:
            first_line = stream.readline()
    except OSError as error:
        return 'cannot read %s: %s' % (output, error.strerror)
    if not first_line.startswith(WRITTEN_BY):
        return ('%s exists and is not a config battery_fit wrote: it is left alone (remove it, or give another '
                'file name)' % output)
    return None


class ProgressBar:
    """A bar redrawn on a terminal; nothing when stderr is not one."""

    def __init__(self, stream):
        self._stream = stream
        self._on = stream.isatty()
        self._start = time.monotonic()

    def __call__(self, fraction, text):
        if not self._on:
            return
        filled = int(round(BAR_WIDTH * min(max(fraction, 0.0), 1.0)))
        self._stream.write('\r[%s%s] %3.0f %%  %5.1f s  %-40s' % ('#' * filled, '.' * (BAR_WIDTH - filled),
                                                                  100.0 * fraction, time.monotonic() - self._start,
                                                                  text[:40]))
        self._stream.flush()

    def done(self):
        if self._on:
            self._stream.write('\n')
            self._stream.flush()


def run(args, stdout=None, stderr=None):
    """Fit, write the config (and plot, profiles), print the report; FitError for a log that cannot be fitted."""
    stdout = stdout or sys.stdout
    bar = ProgressBar(stderr or sys.stderr)
    names = [args.chemistry] if args.chemistry else list(DETECTED)
    try:
        chemistries = [(name, preset(name)) for name in names]
    except ParameterError as error:
        raise FitError(str(error)) from None
    chemistry = chemistries[0][1]
    logs = []
    for index, path in enumerate(args.logs):
        bar(0.0, 'reading %s' % os.path.basename(path))
        logs.extend(split_at_gaps(prepare(read_log(path, args.battery_topic, args.motion_topic),
                                          chemistry.cmd_vel_timeout_s)))
    profile_paths = _profile_paths(args.profiles, logs) if args.profiles else None
    result = fit(logs, chemistry, names[0], cells_series=args.cells_series, holdout=args.holdout,
                 progress=lambda fraction, text: bar(0.05 + 0.85 * fraction, text), alternatives=chemistries[1:])
    bar(0.92, 'replaying the logs through the model')
    numbers = figures(result)
    per_cell_v = numbers.fit_rmse_v / result.params.cells_series
    if not per_cell_v <= MAX_RMSE_PER_CELL_V:   # also NaN
        raise FitError('the fitted model does not reproduce the logs (RMSE %.0f mV per cell on the fitted part): '
                       'are they one battery\'s, with its current? (no config written)' % (1000.0 * per_cell_v))
    command = ' '.join([PROG] + [a for a in sys.argv[1:]]) if sys.argv else PROG
    text = config_text(result, command)
    profiles = None
    if args.profiles:
        profiles = _write_profiles(profile_paths, logs)
    if args.plot:
        bar(0.97, 'plotting')
        plot(args.plot, result, numbers)
    write_config(args.output, text)   # last: interrupted or failed before this, no config is written
    bar(1.0, 'done')
    bar.done()
    stdout.write(report_text(result, numbers, args.output, args.holdout, profiles))


def _profile_paths(directory, logs):
    """The profile files of ``logs`` in ``directory``; FitError (before the fit) when one exists already: a
    user's file is never written over."""
    paths = [os.path.join(directory, 'profile_%d_%s.csv' % (index + 1, os.path.basename(log.name.rstrip('/'))
                                                            .replace('.', '_'))) for index, log in enumerate(logs)]
    existing = [path for path in paths if os.path.exists(path)]
    if existing:
        raise FitError('--profiles: %s exists already (it is left alone: give another directory)' % existing[0])
    return paths


def _write_profiles(paths, logs):
    try:
        os.makedirs(os.path.dirname(paths[0]) or '.', exist_ok=True)
        for path, log in zip(paths, logs):
            write_profile(path, log)
        return paths
    except OSError as error:
        raise FitError('cannot write the profile %s: %s' % (path, error.strerror)) from None


def plot(path, result, numbers):
    """The logs' voltage against the model's (the held-out part shaded), and the residuals per cell."""
    try:
        import matplotlib
        matplotlib.use('Agg')
        import matplotlib.pyplot as plt
    except ImportError:
        raise FitError('--plot needs matplotlib (python3-matplotlib)') from None
    series = result.params.cells_series
    figure, (top, bottom) = plt.subplots(2, 1, figsize=(10, 6.5), sharex=True, gridspec_kw={'height_ratios': [2, 1]})
    offset = 0.0
    for index, (log, model, mask) in enumerate(zip(result.logs, numbers.model_voltage, result.fit_masks)):
        hours = (log.time_s + offset) / 3600.0
        top.plot(hours, log.voltage_v, color='tab:blue', lw=0.8, label='log' if index == 0 else None)
        top.plot(hours, model, color='tab:orange', lw=0.8, label='fitted model (replayed)' if index == 0 else None)
        bottom.plot(hours, 1000.0 * (model - log.voltage_v) / series, color='tab:gray', lw=0.6)
        if (~mask).any():
            for axis in (top, bottom):
                axis.axvspan(hours[~mask][0], hours[-1], color='tab:red', alpha=0.08,
                             label='held out' if index == 0 and axis is top else None)
        offset += log.time_s[-1] + 60.0
    top.set_ylabel('pack voltage, V')
    top.set_title('battery_fit: held-out RMSE %.1f mV per cell, fitted part %.1f mV per cell'
                  % (1000.0 * numbers.holdout_rmse_v / series, 1000.0 * numbers.fit_rmse_v / series))
    top.legend(loc='best')
    bottom.set_ylabel('model - log, mV per cell')
    bottom.set_xlabel('time, h (logs one after another)')
    bottom.axhline(0.0, color='black', lw=0.5)
    figure.tight_layout()
    try:
        key = PLOT_METADATA_KEY.get(_extension(path) or 'png')   # (matplotlib's default format)
        figure.savefig(path, dpi=90, metadata={key: PLOT_MARK} if key else None)
    except OSError as error:
        raise FitError('cannot write the plot %s: %s' % (path, error.strerror)) from None
    finally:
        plt.close(figure)


def main(argv=None):
    try:
        args = parse_arguments(argv)   # (--plot's check loads matplotlib: a Ctrl-C can come then too)
        run(args)
    except FitError as error:
        sys.stderr.write('\n' if sys.stderr.isatty() else '')
        sys.exit('%s: %s' % (PROG, error))
    except KeyboardInterrupt:
        sys.stderr.write('\n%s: interrupted (no config written)\n' % PROG)
        sys.exit(130)


if __name__ == '__main__':
    main()
