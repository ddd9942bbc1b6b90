"""Elapsed simulated time from a clock that may start late or jump (no rospy).

A ROS node under /use_sim_time sees time 0 until the first /clock message,
then whatever the simulator or rosbag says: 1.7e9 s for a bag recorded
today, a jump backwards on every simulator reset or bag loop, and, when a
second /clock publisher interleaves its times with the first (sim_clock beside
Gazebo), jumps back and forth between two lines of time. The battery must age
by the time that passes while it runs, not by those jumps.

Under sim time the readings are sorted into lines of time (one per clock that
publishes, or per restart of one clock): a reading belongs to the line whose
latest reading is the greatest at or below it. Time counts along the line of
the previous reading only; a reading on another known line (the other clock)
switches lines and counts nothing, so two clocks interleaving age the battery
no faster than one of them alone. A forward step much larger than the line's
recent ones (``HOLD_FACTOR``: an update's jitter stays below it) is held until ``CONFIRM_READINGS`` readings carry on
from it and have gone on for as long as the step: an honest clock that stalled
(1000 s of sim_clock at speed 1000, 100 s per update) then counts all of it,
10 updates late; a reading back on the old line first shows it was a second
clock's (its line is remembered, and the old line counts all its own time).
A second clock read alone for longer than its offset is taken for the clock;
should the first one be read again, the jump is owed (not counted twice).

Delivery delays (issue 40): a loaded process reads one clock several times
running, then the other, and may read the first clock once or twice only
before the second's first reading comes. So the start's line holds its first
steps too (a start costs CONFIRM_READINGS readings before it counts, all of
it; a restart's line still counts its first MIN_STEPS steps at once), and a
reading on another known line while a step is held drops that step (at most
one step of time lost).
test_time_base.py injects such delays deterministically. Measured limits
(its delivery model, 11 s): at 20x, clocks 600 and 3000 s apart count at most
1.05 times one clock's time; clocks 40 s apart (within a few updates of each
other) up to 1.19 times; at 60x with stalls of 1 s, up to 1.8 times.
"""
import copy

HOLD_FACTOR = 3.0        # a forward step this many times the line's recent ones is held until confirmed
CONFIRM_READINGS = 6     # readings (the held one included) on from a held step that confirm it, once
                         # they have gone on for as long as the step was (one clock's progress)
MAX_LINES = 4            # lines remembered (the least recently read goes first)
START_HOLD_S = 120.0     # a start's first steps up to this long count at once; longer ones wait for confirmation
MIN_STEPS = 3            # steps a line counts before it holds any
RECENT_STEPS = 10        # steps a line's step size is taken from (the largest of them)


class _Line:
    """One line of time: its latest reading, its recent steps, and a debt."""
    __slots__ = ('last', 'steps', 'debt')

    def __init__(self, last, steps=(), debt=0.0):
        self.last = last
        self.steps = list(steps)   # the last RECENT_STEPS steps > 0 counted along it
        self.debt = debt           # s counted for a confirmed jump away from it, owed should it be read again

    @property
    def step(self):
        """The largest recent step (an update's jitter stays below it); None before the first one."""
        return max(self.steps) if self.steps else None


class TimeBase:
    """Turns readings of a clock into elapsed seconds, scaled by ``time_scale``.

    The first valid reading is a starting point, not elapsed time. A reading
    earlier than every line's is a restart (nothing elapses for the jump); so
    is one more than ``max_jump_s`` after its line's latest (None: no bound).
    A reading of 0 under sim time means "no clock yet" and is skipped.
    ``hold_jumps`` (sim time): big forward steps wait for confirmation (the
    module's docstring); without it every forward step counts at once.
    """

    def __init__(self, time_scale=1.0, zero_is_unset=False, max_jump_s=None, hold_jumps=False):
        self.time_scale = time_scale
        self.max_jump_s = max_jump_s
        self._zero_is_unset = zero_is_unset
        self._hold_jumps = hold_jumps
        self._lines = []          # known lines, the least recently read first
        self._first_line = None   # the line of the first reading (the start): it holds its first steps too
        self._line = None         # the line of the previous reading
        self._previous = None     # the previous reading
        self._held = None         # [first, latest, readings, largest step] of a held step from self._line
        self._debt = 0.0          # s counted for a jump that proved to be another clock's, not counted again
        self.jumps_back = 0       # readings earlier than the previous one (a restart or the other clock)
        self.jumps_forward = 0    # forward jumps beyond max_jump_s seen

    @property
    def restarts(self):
        """Restarts of the base so far (jumps either way)."""
        return self.jumps_back + self.jumps_forward

    @property
    def holding(self):
        """True while a big forward step waits for confirmation (nothing counted for it yet)."""
        return self._held is not None

    def elapsed(self, now):
        """Scaled seconds counted for the reading ``now`` (0 on a start, a restart, a switch between
        clocks or a held step)."""
        if self._zero_is_unset and now <= 0.0:
            return 0.0
        counted = self._take(now)
        repaid = min(counted, self._debt)
        self._debt -= repaid
        return (counted - repaid) * self.time_scale

    def pending(self, now):
        """What the next ``elapsed(now)`` would return, without taking ``now`` as a reading."""
        return copy.deepcopy(self).elapsed(now)

    # -- the rule ------------------------------------------------------------------------

    def _take(self, now):
        previous, self._previous = self._previous, now
        if self._line is None:
            self._new_line(now)
            return 0.0
        if self._held is not None and self._on_another_line(now):
            self._held = None   # another clock's reading while a step waits: that step stays unconfirmed (its
                                # time is lost, at most one step; counting it let a second clock's jump count)
        if self._held is not None:
            first, latest, readings, largest = self._held
            step = now - latest
            if now >= latest and not self._big(self._line, step, largest):   # on from the held step
                largest = max(largest, step)
                if readings + 1 < CONFIRM_READINGS or now - first < first - self._line.last:
                    self._held = [first, now, readings + 1, largest]
                    return 0.0
                self._held = None                   # confirmed: one clock that stepped far (or a second
                origin = self._line                 # clock that ran alone for a while: its line is kept,
                steps = origin.steps                # and the jump is owed should a reading land on it)
                self._remember(_Line(origin.last, steps, first - origin.last - max(steps, default=0.0)))
                return self._count(origin, now, step)
            if now >= latest:                       # far on again: the held part counts, the rest is held
                counted = self._count(self._line, latest, latest - self._line.last)
                self._hold(now, step)
                return counted
            self._held = None                       # back below it: the held reading was another clock's
            self._remember(_Line(latest, self._line.steps))
        below = [line for line in self._lines if line.last <= now]
        line = max(below, key=lambda line: line.last) if below else None
        if line is None:                            # earlier than every line: a restart
            self.jumps_back += 1
            self._new_line(now)
            return 0.0
        if self.max_jump_s is not None and now - line.last > self.max_jump_s:
            self.jumps_forward += 1                 # beyond the bound: a restart
            self._new_line(now)
            return 0.0
        current = self._line
        step = now - current.last
        if line is not current:
            if now >= previous and len(current.steps) >= MIN_STEPS and step <= HOLD_FACTOR * current.step:
                self._lines.remove(line)            # the line passed a line no clock reads any more
            else:
                if now < previous:                  # back to another known line: the other clock
                    self.jumps_back += 1
                self._debt += line.debt             # a jump away from it was the other clock's
                line.debt = 0.0
                self._line = line                   # a switch between clocks counts nothing
                line.last = now
                self._remember(line)
                return 0.0
        if self._big(current, step):
            self._hold(now, step)
            return 0.0
        return self._count(current, now, step)

    def _on_another_line(self, now):
        """Whether ``now`` is a step of usual size on a known line other than the previous reading's."""
        below = [line for line in self._lines if line.last <= now]
        line = max(below, key=lambda line: line.last) if below else None
        return line is not None and line is not self._line and bool(line.steps) and \
            now - line.last <= HOLD_FACTOR * line.step

    def _big(self, line, step, largest=0.0):
        """A step to hold: far beyond the line's recent ones (and ``largest``). The start's line holds its
        first steps too (a restart's holds from MIN_STEPS steps on): with nothing to compare them with, a
        reading of another clock (its first, 600 s ahead, while a loaded process had read the first clock
        once or twice) cannot be told from a step of this one, and counting it drained 600 s at once."""
        if len(line.steps) < MIN_STEPS and line is not self._first_line:
            return False   # a restart's line counts its first steps at once, as Part 2 says (no second clock
                           # unknown by then: the other clock's line was met before the restart)
        if len(line.steps) < MIN_STEPS and step <= START_HOLD_S:
            return False   # the start's first steps of usual size count at once (held, the ROS 1 demo at speed
                           # 240 docked 4 points under its low level); a second clock closer than this counts
                           # at most this much once
        return self._hold_jumps and step > HOLD_FACTOR * max(line.steps + [largest])

    def _hold(self, now, step):
        """Hold the step to ``now`` from the line of the previous reading; on a line with no step yet, the
        held step is the size the readings on from it are compared with."""
        self._held = [now, now, 1, 0.0 if self._line.steps else step]

    def _count(self, line, now, step):
        counted = now - line.last
        line.last = now
        if step > 0.0:
            line.steps = line.steps[1 - RECENT_STEPS:] + [step]
        self._remember(line)
        return counted

    def _new_line(self, now):
        self._line = _Line(now)
        if self._first_line is None:
            self._first_line = self._line
        self._remember(self._line)

    def _remember(self, line):
        if line in self._lines:
            self._lines.remove(line)
        self._lines.append(line)
        del self._lines[:-MAX_LINES]
