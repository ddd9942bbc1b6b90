"""Log lines of one battery among many through an rclpy logger (core/battery_log.py: the name in front,
throttled per robot; ros1/log.py's twin)."""
from battery_simulator.core.battery_log import BatteryLog


class RobotLog(BatteryLog):
    """An rclpy logger's lines for one battery: ``prefix`` before every line; the progress lines only when
    ``progress`` (a single battery's node: a fleet host logs none).

    rclpy ties each call site of a logger to one severity ("Logger severity cannot be changed between
    calls"), so each severity is written from a function of its own, never from BatteryLog's one line.
    """

    def __init__(self, logger, prefix='', progress=False):
        def info(text):
            logger.info(text)

        def warn(text):
            logger.warning(text)

        def error(text):
            logger.error(text)
        super().__init__(info, warn, error, prefix, progress)
