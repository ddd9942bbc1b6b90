"""Log lines of one battery among many, for any ROS (no ROS import): the robot's name in front, throttled
per robot and message.

rospy's and rclpy's throttles key on the line of code, so in a fleet host one
robot's line would silence every other robot's; this keys on the robot (the
object) and the message. The front ends give the functions that write a line
(ros1/log.py for rospy, ros2/log.py for rclpy).
"""
import time


class BatteryLog:
    """info/warn/error (printf-style arguments) and their ``*_throttle`` forms, ``progress`` (nothing when
    ``progress`` is false: a fleet host logs no level-by-level progress), each line after ``prefix``."""

    def __init__(self, info, warn, error, prefix='', progress=True):
        self._write = {'info': info, 'warn': warn, 'error': error}
        self.prefix = prefix
        self._progress = progress
        self._last = {}   # (level, format) -> monotonic time last written

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

