"""Log lines of one battery among many, for any ROS (no ROS import): the robot's name in front, throttled
per robot and message.

rospy's and rclpy's throttles key on the line of code, so in a fleet host one
robot's line would silence every other robot's; this keys on the robot (the
object) and the message. The front ends give the functions that write a line
(ros1/log.py for rospy, ros2/log.py for rclpy).
"""
import time

#: a transition (the charger connected or disconnected) counts as one when the state it left had stood this
#: long (wall time): each such change is said at once, on a line of its own. A change sooner than that after
#: the last is a bounce (contact plates chattering, a robot that touches the dock for a tick, a test's 500 Hz
#: flapping): bounces are counted, and said on one line once the state has stood this long again (at the
#: latest every BOUNCE_REPORT_S while it keeps bouncing), naming the state it ended in. So every change is
#: in the log, none hidden by a throttle, and a bouncing contact writes at most a line a second.
SETTLE_S = 1.0
BOUNCE_REPORT_S = 10.0


class BatteryLog:
    """info/warn/error (printf-style arguments) and their ``*_throttle`` forms, ``progress`` (nothing when
    ``progress`` is false: a fleet host logs no level-by-level progress), each line after ``prefix``."""

    def __init__(self, info, warn, error, prefix='', progress=True):
        self._write = {'info': info, 'warn': warn, 'error': error}
        self.prefix = prefix
        self._progress = progress
        self._last = {}   # (level, format) -> monotonic time last written
        self._changed_at = -float('inf')   # monotonic time of the last transition
        self._bounces = None   # while bouncing: [changes counted, since, the line of the state now, reported at]

    def _line(self, level, text, args):
        self._write[level](self.prefix + (text % args if args else text))

    def progress(self, text, *args):
        if self._progress:
            self._line('info', text, args)

    def info(self, text, *args):
        self._line('info', text, args)

    def warn(self, text, *args):
        self._line('warn', text, args)

    def error(self, text, *args):
        self._line('error', text, args)

    def info_throttle(self, period_s, text, *args):
        self._throttled('info', period_s, text, args)

    def warn_throttle(self, period_s, text, *args):
        self._throttled('warn', period_s, text, args)

    def error_throttle(self, period_s, text, *args):
        self._throttled('error', period_s, text, args)

    def _throttled(self, level, period_s, text, args):
        now = time.monotonic()
        key = (level, text)
        if now - self._last.get(key, -period_s) >= period_s:
            self._last[key] = now
            self._line(level, text, args)


    def transition(self, text, *args):
        """A change of state (the charger connected or disconnected): said at once when the state before it
        had stood SETTLE_S, else counted as a bounce (``settle`` says it). ``text % args`` names the new state."""
        now = time.monotonic()
        line = text % args if args else text
        if self._bounces is None and now - self._changed_at >= SETTLE_S:
            self._line('info', line, ())
        elif self._bounces is None:
            self._bounces = [1, self._changed_at, line, now]
        else:
            self._bounces[0] += 1
            self._bounces[2] = line
        self._changed_at = now

    def settle(self):
        """Say the bounces counted, once the state has stood SETTLE_S (or every BOUNCE_REPORT_S while it keeps
        bouncing): the line of the state it is in now, with how many changes it took since when. The front
        end calls it at every update."""
        if self._bounces is None:
            return
        now = time.monotonic()
        count, since, line, reported = self._bounces
        if now - self._changed_at >= SETTLE_S:
            if count:   # (none since the last "still bouncing" line: that said the state)
                    self._line('info', '%s (after %d change(s) in %.1f s: a bouncing contact)',
                           (line, count, self._changed_at - since))
            self._bounces = None
        elif now - reported >= BOUNCE_REPORT_S:
            self._line('info', '%s (still bouncing: %d change(s) in %.1f s)', (line, count, now - since))
            self._bounces = [0, now, line, now]
