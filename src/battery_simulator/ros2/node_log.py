"""Log lines of one battery among many through an rclpy logger: the robot's name in front,
throttled per robot and message (the rclpy twin of battery/robot_log.py)."""
import time


class NodeLog:
    """info/warn/error and their ``*_throttle`` forms, with printf-style arguments, on an rclpy logger."""

    def __init__(self, logger, prefix='', progress=True):
        self._logger = logger
        self.prefix = prefix
        self._progress = progress   # a fleet host logs no level-by-level progress
        self._last = {}             # (level, format) -> monotonic time last logged

    def _line(self, text, args):
        return self.prefix + (text % args if args else text)

    def progress(self, text, *args):
        if self._progress:
            self._logger.info(self._line(text, args))

    def info(self, text, *args):
        self._logger.info(self._line(text, args))

    def warn(self, text, *args):
        self._logger.warning(self._line(text, args))

    def error(self, text, *args):
        self._logger.error(self._line(text, args))

    def fatal(self, text, *args):
        self._logger.fatal(self._line(text, args))

    def info_throttle(self, period_s, text, *args):
        self._throttled(self.info, period_s, text, args)

    def warn_throttle(self, period_s, text, *args):
        self._throttled(self.warn, period_s, text, args)

    def error_throttle(self, period_s, text, *args):
        self._throttled(self.error, period_s, text, args)

    def _throttled(self, log, period_s, text, args):
        now = time.monotonic()
        key = (log, text)
        if now - self._last.get(key, -period_s) >= period_s:
            self._last[key] = now
            log(text, *args)
