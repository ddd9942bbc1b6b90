"""Log lines of one battery among many through an rclpy logger (core/battery_log.py: the name in front,
throttled per robot)."""
from battery_simulator.core.battery_log import BatteryLog


class NodeLog(BatteryLog):
    """An rclpy logger's lines for one battery."""

    def __init__(self, logger, prefix='', progress=True):
        super().__init__(logger.info, logger.warning, logger.error, prefix, progress)
