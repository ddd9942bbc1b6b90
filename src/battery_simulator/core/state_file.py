"""A battery's state in a JSON file (``state_file``): read at start, written atomically, held by one battery
at a time (no ROS import)."""
import fcntl
import json
import math
import os
import tempfile
import time

from battery_simulator.core.gauge import SAVED_KEYS as GAUGE_SAVED_KEYS

#: a save that fails (a full disk) is reported at most this often
WRITE_ERROR_PERIOD_S = 60.0


class StateFileError(ValueError):
    """A ``state_file`` that cannot be used: the reason (the caller names the parameter and the path)."""


def check_state_file(path, fleet=False, holder=None):
    """Check at start that ``path`` can hold a state file (a fleet's when ``fleet``): no file yet, an empty
    one, or a state file of that kind, in a directory it can be written to. Else StateFileError: a file
    that exists and is not a state file is never written over, and an unwritable path is said once.

    With ``holder`` (the battery's or the fleet host's name), the file is then held for ``holder`` until
    this process ends (hold_state_file): a second battery given the same file is refused."""
    if os.path.isdir(path):
        raise StateFileError('it is a directory')
    if os.path.exists(path) and os.path.getsize(path) > 0:
        kind = "a fleet's state file" if fleet else 'a state file'
        try:
            saved = read_state_file(path)
        except (OSError, ValueError) as error:
            raise StateFileError('the file exists and is not %s (%s); it is never written over: give another '
                                 'path, or move that file away' % (kind, str(error).splitlines()[0])) from None
        if not is_state(saved, fleet):
            raise StateFileError('the file exists and is not %s; it is never written over: give another path, '
                                 'or move that file away' % kind)
    try:
        descriptor, probe = tempfile.mkstemp(prefix='.state_probe_', dir=os.path.dirname(os.path.abspath(path)))
        os.close(descriptor)
        os.remove(probe)
    except OSError as error:
        raise StateFileError('it cannot be written (%s)' % (error.strerror or error)) from None
    if holder is not None:
        hold_state_file(path, holder)


#: a state file's lock: this beside it (the state file itself is replaced at every write)
LOCK_SUFFIX = '.lock'
_held = {}   # real path of a state file -> the open lock file that holds it (for the process's life)


def hold_state_file(path, holder):
    """Hold ``path`` for ``holder`` while this process runs: an exclusive flock on ``path`` + LOCK_SUFFIX,
    which names the holder and its process id. The kernel drops the lock when the process ends however it
    ends, so a battery killed with SIGKILL does not block its restart. StateFileError naming the battery
    that holds it when another process does (or another holder of this one)."""
    key = os.path.realpath(path)
    if key in _held:
        if _held[key][1] == holder:
            return
        raise StateFileError('it is the state file of %s, which runs in this process; give each battery a '
                             'state file of its own' % _held[key][1])
    lock_path = path + LOCK_SUFFIX
    try:
        stream = open(lock_path, 'a+', encoding='utf-8')
    except OSError as error:
        raise StateFileError('its lock %s cannot be opened (%s)' % (lock_path, error.strerror or error)) from None
    try:
        fcntl.flock(stream, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        stream.seek(0)
        named = stream.read().strip() or 'another process (it has not said which yet)'
        stream.close()
        raise StateFileError('another battery runs with it: %s; give each battery a state file of its own'
                             % named) from None
    stream.seek(0)
    stream.truncate()
    stream.write('%s (process %d)\n' % (holder, os.getpid()))
    stream.flush()
    _held[key] = (stream, holder)


def release_state_file(path):
    """Let ``path`` go (a test, or a node that ends but not its process); the lock file stays, unheld."""
    held = _held.pop(os.path.realpath(path), None)
    if held is not None:
        held[0].close()


def is_state(saved, fleet=False):
    """Whether ``saved`` (a JSON file's content) is a state file: one battery's, or a fleet's."""
    if fleet:
        return isinstance(saved, dict) and isinstance(saved.get('robots'), dict)
    return isinstance(saved, dict) and 'state_of_charge' in saved


def read_state_file(path):
    """The saved state in ``path``, or None when there is no file; OSError/ValueError when it cannot be read."""
    if not path or not os.path.exists(path) or os.path.getsize(path) == 0:
        return None
    with open(path, encoding='utf-8') as stream:
        return json.load(stream)


def write_state_file(path, state):
    """Write ``state`` to ``path`` through a temporary file: never a half-written file. OSError on failure."""
    temporary = path + '.tmp'
    with open(temporary, 'w', encoding='utf-8') as stream:
        json.dump(state, stream, indent=1)
    os.replace(temporary, path)


SAVE_EVERY_PERCENT = 0.1       # save when the level moved this much ...
SAVE_EVERY_S = 2.0             # ... or this long (wall) has passed
FLEET_SAVE_PERIOD_S = 0.5      # a fleet's saved states (file, or ROS 1's parameter) are written at most this often,
FLEET_SAVE_BATTERY_S = 20.0    # and sooner where that is more battery time than this (a resume after SIGKILL
MIN_FLEET_SAVE_PERIOD_S = 0.05  # within 1 %: 20 s at 1.5 A of 3 Ah is 0.3 %), but not more often than this


#: a write asked for this fraction of a period early (a timer's jitter) is made: comparing with the period
#: exactly skipped every other tick of a timer at the period (1.0 s at x22 for 0.5 s; 0.13 s at x300 for 0.067 s)
SAVE_EARLY = 0.2


class SaveCadence:
    """When a saved state written every ``period_s`` (wall s) is due, whoever asks (a timer at the period, a
    loop at another rate): a period after the last write, up to SAVE_EARLY of a period early (so writes are
    at most (1 + SAVE_EARLY) periods apart when a timer asks at the period, and at most 1 / (1 - SAVE_EARLY)
    a period)."""

    def __init__(self, period_s):
        self.period_s = period_s
        self._written_at = -math.inf

    def due(self, now):
        return now - self._written_at >= (1.0 - SAVE_EARLY) * self.period_s

    def wrote(self, now):
        self._written_at = now


def fleet_save_period_s(time_scale=1.0):
    """How often a fleet's saved states are written, wall s: FLEET_SAVE_PERIOD_S, or as much wall time as
    FLEET_SAVE_BATTERY_S of battery at ``time_scale`` (1 under sim time), at least MIN_FLEET_SAVE_PERIOD_S
    (at x300: 0.067 s; at x10000 a resume can be 500 s of battery behind)."""
    return min(FLEET_SAVE_PERIOD_S, max(MIN_FLEET_SAVE_PERIOD_S, FLEET_SAVE_BATTERY_S / time_scale))


class SaveThrottle:
    """When one battery's saved state is written: at the first update, then when its level moved
    SAVE_EVERY_PERCENT or SAVE_EVERY_S (wall) passed since the last write. The one rule of every keeper (ROS 1's
    parameter and a fleet robot's, the state file of either front end)."""

    def __init__(self, clock=time.monotonic):
        self._clock = clock
        self._saved = (None, None, -math.inf)   # (level %, the gauge's, time) of the last write

    def due(self, state):
        saved_level, saved_gauge, saved_at = self._saved
        return saved_level is None or abs(100.0 * state['state_of_charge'] - saved_level) >= SAVE_EVERY_PERCENT \
            or _gauge_moved(_gauge_kept(state), saved_gauge) or self._clock() - saved_at >= SAVE_EVERY_S

    def wrote(self, state):
        self._saved = (100.0 * state['state_of_charge'], _gauge_kept(state), self._clock())


def _gauge_kept(state):
    """What a gauge keeps in a saved state (core/gauge.py SAVED_KEYS; None where it keeps none): a learning
    gauge's rest reading, learned capacity, zero lock or end of charge moves it while the truth stands still."""
    return tuple(state.get(key) for key in GAUGE_SAVED_KEYS)


def _gauge_moved(kept, saved):
    """The gauge's level moved SAVE_EVERY_PERCENT, or another of its kept values changed."""
    if kept[0] != saved[0] and (kept[0] is None or saved[0] is None
                                or abs(100.0 * (kept[0] - saved[0])) >= SAVE_EVERY_PERCENT):
        return True
    return kept[1:] != saved[1:]


class StateFileKeeper:
    """Keeps one battery's state in a state file (the format ROS 1's ~state_file has): written when
    SaveThrottle says, and at shutdown. ``log(text)`` reports a file that cannot be read or written.
    ``load()`` and ``where`` as every keeper's (ros1/saved_state.py StateStore's)."""

    def __init__(self, path, log=None, clock=time.monotonic):
        self.path = path
        self.where = path
        self._log = log or (lambda text: None)
        self._clock = clock
        self._throttle = SaveThrottle(clock)
        self._error_at = -WRITE_ERROR_PERIOD_S

    def load(self):
        """The saved state, or None (no file); a file that cannot be read is reported and ignored."""
        try:
            return read_state_file(self.path)
        except (OSError, ValueError) as error:
            self._log('cannot read state file %s (%s): starting fresh' % (self.path, error))
            return None

    def maybe_save(self, state):
        """Write ``state`` if SaveThrottle says it is due."""
        if self._throttle.due(state):
            self.save_now(state)

    def save_now(self, state):
        try:
            write_state_file(self.path, state)
            self._throttle.wrote(state)
        except OSError as error:
            _write_failed(self, error)


class FleetStateFile:
    """Every robot's state of a fleet host in one state file ({"robots": {name: state}}), written at
    most every ``period_s`` (fleet_save_period_s) whatever the number of robots, and at shutdown."""

    def __init__(self, path, log=None, clock=time.monotonic, period_s=FLEET_SAVE_PERIOD_S):
        self.path = path
        self.period_s = period_s
        self._log = log or (lambda text: None)
        self._clock = clock
        self._states = {}
        self._cadence = SaveCadence(period_s)
        self._error_at = -WRITE_ERROR_PERIOD_S
        try:
            saved = read_state_file(path)
            self._saved = saved.get('robots', {}) if isinstance(saved, dict) else {}
        except (OSError, ValueError, AttributeError) as error:
            self._log('cannot read state file %s (%s): starting fresh' % (path, error))
            self._saved = {}

    def robot(self, name):
        """The keeper of one robot's state (load, maybe_save, save_now)."""
        return _RobotKeeper(self, name)

    def write_if_due(self, force=False):
        """Write every robot's state if a write is due (SaveCadence) or ``force``; True when written."""
        now = self._clock()
        if self._states and (force or self._cadence.due(now)):
            self._cadence.wrote(now)
            try:
                write_state_file(self.path, {'robots': self._states})
            except OSError as error:
                _write_failed(self, error)
            return True
        return False


def _write_failed(keeper, error):
    """Report a failed save (a full disk, a directory removed) at most every WRITE_ERROR_PERIOD_S."""
    now = keeper._clock()
    if now - keeper._error_at >= WRITE_ERROR_PERIOD_S:
        keeper._error_at = now
        keeper._log('cannot write state file %s: %s' % (keeper.path, error))


class _RobotKeeper:
    def __init__(self, fleet, name):
        self._fleet, self._name = fleet, name
        self.where = 'the fleet state file %s (%s)' % (fleet.path, name)

    def load(self):
        return self._fleet._saved.get(self._name)

    def maybe_save(self, state):
        self._fleet._states[self._name] = state

    def save_now(self, state):
        self._fleet._states[self._name] = state
