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
"""
import copy

HOLD_FACTOR = 3.0        # a forward step this many times the line's recent ones is held until confirmed
CONFIRM_READINGS = 6     # readings (the held one included) on from a held step that confirm it, once
                         # they have gone on for as long as the step was (one clock's progress)
MAX_LINES = 4            # lines remembered (the least recently read goes first)
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
                self._remember(_Line(origin.last, steps, first - origin.last - max(steps)))
                return self._count(origin, now, step)
            if now >= latest:                       # far on again: the held part counts, the rest is held
                self._held = [now, now, 1, 0.0]
                return self._count(self._line, latest, latest - self._line.last)
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
            self._held = [now, now, 1, 0.0]
            return 0.0
        return self._count(current, now, step)

    def _big(self, line, step, largest=0.0):
        """A step to hold: far beyond the line's recent ones (and ``largest``); a line of fewer than
        MIN_STEPS steps (after a start or a restart) holds nothing."""
        return self._hold_jumps and len(line.steps) >= MIN_STEPS and step > HOLD_FACTOR * max(line.step, largest)

    def _count(self, line, now, step):
        counted = now - line.last
        line.last = now
        if step > 0.0:
            line.steps = line.steps[1 - RECENT_STEPS:] + [step]
        self._remember(line)
        return counted

    def _new_line(self, now):
        self._line = _Line(now)
        self._remember(self._line)

    def _remember(self, line):
        if line in self._lines:
            self._lines.remove(line)
        self._lines.append(line)
        del self._lines[:-MAX_LINES]
