"""battery_fit's ROS-free side: a robot's logs in, a battery config out (contract Part 8).

    log_reader.py     a ROS 1 bag, a ROS 2 bag (MCAP, sqlite3) or a CSV -> RawLog (rosbags, or Debian's rosbag)
    conventions.py    the log's conventions found and undone: current sign, percentage scale, NaN, stamps
    circuit.py        the equivalent circuit as arrays: what the voltage is for given parameters (fast)
    fitting.py        the fits: series count, capacity, OCV (offset or curve), resistances, loads, charger, heat
    config_writer.py  the config YAML, each fitted value commented with its source and uncertainty
    report.py         the figures through the real model (as battery_replay computes them), the report text
"""


class FitError(ValueError):
    """A log cannot be fitted; the message is one line saying which log and why."""
