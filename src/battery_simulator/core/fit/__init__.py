"""battery_fit's ROS-free side: a robot's logs in, a battery config out (contract Part 8).

    log_reader.py     a ROS 1 bag, a ROS 2 bag (MCAP, sqlite3) or a CSV -> RawLog (rosbags, or Debian's rosbag)
    conventions.py    the log's conventions found and undone: current sign, percentage scale, NaN, stamps
    circuit.py        the equivalent circuit as arrays: what the voltage is for given parameters (fast)
    fitting.py        fit(): the fits below in order, the learned OCV curve or the preset's shape chosen by replay
    known.py          what the logs fix before any fit: units, fitted part, rests, capacity and SOC (percentage,
                      a full charge, a cut-off)
    series.py         the series count (and the chemistry among candidates) from the voltage range
    electrical.py     capacity, starting SOCs, OCV offset, resistances and time constants; their config values
    ocv_curve.py      the OCV curve learned over the covered SOC range (cross-validated against the preset's)
    loads_charger.py  idle and motion loads, the charger (CC current, CV voltage), the datasheet currents
    heat.py           ambient, heat capacity and transfer from the logged temperature
    config_writer.py  the config YAML, each fitted value commented with its source and uncertainty
    report.py         the figures through the real model (as battery_replay computes them), the report text
"""
from dataclasses import dataclass


class FitError(ValueError):
    """A log cannot be fitted; the message is one line saying which log and why."""


@dataclass
class Fitted:
    """One value written to the config: how it was found and how well (None: not estimated)."""

    value: object
    source: str
    uncertainty: float = None
