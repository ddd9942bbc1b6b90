"""Read a robot's battery log: a ROS 1 bag, a ROS 2 bag (MCAP or sqlite3 storage) or a CSV (no ROS needed).

Bags are read with the pure-Python ``rosbags`` library (all three formats); without it, a ROS 1 bag is read
with Debian's ``rosbag`` (python3-rosbag) and a ROS 2 bag is refused with one line saying what to install.
tools/install_dependencies.sh puts rosbags into build/python_deps, which is searched when rosbags is not
installed otherwise. Topics are found by type (sensor_msgs/BatteryState; geometry_msgs/Twist, TwistStamped
or nav_msgs/Odometry for motion) unless named.
"""
import csv
import gzip
import itertools
import math
import sys
import zlib
from array import array
from dataclasses import dataclass, field
from pathlib import Path

from battery_simulator.core.fit import FitError

BATTERY_TYPE = 'sensor_msgs/msg/BatteryState'
MOTION_TYPES = ('geometry_msgs/msg/Twist', 'geometry_msgs/msg/TwistStamped', 'nav_msgs/msg/Odometry')
CSV_COLUMNS = ('time', 'voltage', 'current')
CSV_OPTIONAL = ('temperature', 'percentage', 'linear_x', 'angular_z')
#: a CSV's header line is at most this long (read no further when it has no line end)
HEADER_CHARS = 65536
#: where tools/install_dependencies.sh installs rosbags (pip --target), below the source or install tree
PYTHON_DEPS = 'build/python_deps'


@dataclass
class RawLog:
    """What a log holds, as read: battery samples (time s, voltage V, current A, temperature degC,
    percentage; NaN where unmeasured) and motion samples (time s, |linear x| m/s, |angular z| rad/s)."""

    name: str
    time_s: list = field(default_factory=list)
    voltage_v: list = field(default_factory=list)
    current_a: list = field(default_factory=list)
    temperature_c: list = field(default_factory=list)
    percentage: list = field(default_factory=list)
    motion_time_s: list = None
    linear_mps: list = None
    angular_radps: list = None
    #: BatteryState.cell_voltage: how many entries it had (0: none) and, per sample, their sum (NaN: none)
    cell_count: int = 0
    cell_sum_v: list = field(default_factory=list)
    #: where the samples came from (topic names, columns)
    source: str = ''
    notes: list = field(default_factory=list)


def read_log(path, battery_topic=None, motion_topic=None):
    """A RawLog from ``path``; FitError (one line) when it cannot be read or holds no battery samples."""
    path = Path(path)
    if not path.exists():
        raise FitError('%s: no such file or directory' % path)
    if path.is_dir() or path.suffix.lower() in ('.bag', '.mcap', '.db3'):
        return _read_bag(path, battery_topic, motion_topic)
    try:
        with open(path, 'rb') as stream:
            head = stream.read(16)
    except OSError as error:
        raise FitError('%s: cannot read: %s' % (path, error.strerror)) from None
    if head.startswith(b'#ROSBAG') or head.startswith(b'\x89MCAP') or head.startswith(b'SQLite format'):
        return _read_bag(path, battery_topic, motion_topic)
    return _read_csv(path, gzipped=head.startswith(b'\x1f\x8b'))


# -- CSV ------------------------------------------------------------------------------------------------

def _read_csv(path, gzipped=False):
    """Streamed into arrays of doubles (a CSV of ten million rows stays within memory)."""
    opener = gzip.open if gzipped else open
    try:
        with opener(path, 'rt', newline='', encoding='utf-8-sig') as stream:
            first = stream.readline(HEADER_CHARS)   # bounded: /dev/zero or a file of zero bytes has no line end
            if len(first) == HEADER_CHARS and not first.endswith(('\n', '\r')):
                raise FitError('%s: not a CSV log: its first line is longer than %d characters (a CSV needs a header: '
                               '%s)' % (path, HEADER_CHARS, ', '.join(CSV_COLUMNS)))
            rows = csv.reader(itertools.chain([first], stream))
            try:
                header = [name.strip().lower() for name in next(rows)]
            except StopIteration:
                raise FitError('%s: empty file (a CSV needs a header: %s)' % (path, ', '.join(CSV_COLUMNS))) from None
            missing = [name for name in CSV_COLUMNS if name not in header]
            if missing:
                raise FitError('%s line 1: the header must name the columns %s (and optionally %s), got %s'
                               % (path, ', '.join(CSV_COLUMNS), ', '.join(CSV_OPTIONAL),
                                  ','.join(header)[:200] or 'nothing'))
            columns = [(name, header.index(name)) for name in CSV_COLUMNS + CSV_OPTIONAL if name in header]
            values = {name: array('d') for name, _ in columns}
            appends = [(values[name].append, index, name) for name, index in columns]
            width = max(index for _, index in columns) + 1
            for line, row in enumerate(rows, start=2):
                if len(row) < width:
                    if not row or all(not cell.strip() for cell in row):
                        continue
                    row = row + [''] * (width - len(row))
                for append, index, name in appends:
                    text = row[index]
                    try:
                        append(float(text) if text.strip() else math.nan)
                    except ValueError:
                        raise FitError('%s line %d: column "%s" must be a number (or empty / nan), got %r'
                                       % (path, line, name, text.strip()[:40])) from None
    except OSError as error:
        raise FitError('%s: cannot read: %s' % (path, error.strerror)) from None
    except UnicodeDecodeError as error:
        raise FitError('%s: not a bag and not a UTF-8 text CSV file (byte %d)' % (path, error.start)) from None
    except (EOFError, gzip.BadGzipFile, zlib.error) as error:
        raise FitError('%s: a damaged gzip file: %s' % (path, error)) from None
    except csv.Error as error:
        raise FitError('%s: not a CSV file: %s' % (path, error)) from None
    log = RawLog(name=str(path), source='CSV columns ' + ', '.join(name for name, _ in columns))
    log.time_s = values['time']
    log.voltage_v = values['voltage']
    log.current_a = values['current']
    count = len(log.time_s)
    log.temperature_c = values.get('temperature', array('d', [math.nan]) * count)
    log.percentage = values.get('percentage', array('d', [math.nan]) * count)
    if 'linear_x' in values or 'angular_z' in values:
        log.motion_time_s = log.time_s
        log.linear_mps = values.get('linear_x', array('d', [0.0]) * count)
        log.angular_radps = values.get('angular_z', array('d', [0.0]) * count)
    return log


# -- bags -----------------------------------------------------------------------------------------------

def import_rosbags():
    """The rosbags modules (AnyReader, Stores, get_typestore), or None when not installed anywhere."""
    try:
        from rosbags.highlevel import AnyReader
        from rosbags.typesys import Stores, get_typestore
        return AnyReader, Stores, get_typestore
    except ImportError:
        pass
    here = Path(__file__).resolve()
    candidates = [here.parents[4] / PYTHON_DEPS]   # <source>/src/battery_simulator/core/fit/
    if len(here.parents) > 6:   # <prefix>/lib/python3/dist-packages/battery_simulator/core/fit/
        candidates.append(here.parents[6] / 'share' / 'battery_simulator' / 'python_deps')
    for candidate in candidates:
        if (candidate / 'rosbags').is_dir() and str(candidate) not in sys.path:
            sys.path.append(str(candidate))   # last: the system's numpy stays the one imported
            try:
                from rosbags.highlevel import AnyReader
                from rosbags.typesys import Stores, get_typestore
                return AnyReader, Stores, get_typestore
            except ImportError:
                continue
    return None


def _bag_paths(path):
    """The path AnyReader takes: a ROS 2 bag is its directory (metadata.yaml), or a lone .mcap file."""
    if path.is_dir():
        if not (path / 'metadata.yaml').is_file():
            raise FitError('%s: a directory but not a ROS 2 bag (no metadata.yaml)' % path)
        return path, 2
    with open(path, 'rb') as stream:
        head = stream.read(16)
    if head.startswith(b'#ROSBAG'):
        return path, 1
    if (path.parent / 'metadata.yaml').is_file():
        return path.parent, 2
    if head.startswith(b'\x89MCAP'):
        return path, 2
    if not head:
        raise FitError('%s: empty file (no bag header)' % path)
    raise FitError('%s: not a ROS bag (no ROS 1 bag header, no MCAP magic, no metadata.yaml beside it)' % path)


def _read_bag(path, battery_topic, motion_topic):
    try:
        bag_path, version = _bag_paths(path)
    except OSError as error:
        raise FitError('%s: cannot read: %s' % (path, error.strerror)) from None
    modules = import_rosbags()
    if modules is None:
        if version == 1:
            return _read_ros1_with_rosbag(path, battery_topic, motion_topic)
        raise FitError('%s: reading a ROS 2 bag needs the Python library rosbags: pip install rosbags '
                       '(or run tools/install_dependencies.sh)' % path)
    any_reader, stores, get_typestore = modules
    try:
        reader = any_reader([Path(bag_path)], default_typestore=get_typestore(stores.ROS2_HUMBLE))
        reader.open()
    except Exception as error:   # rosbags raises its own errors for every kind of damage
        raise FitError('%s: cannot read the bag: %s' % (path, ' '.join(str(error).split()) or type(error).__name__)) from None
    try:
        return _messages(path, reader, battery_topic, motion_topic)
    finally:
        reader.close()


def _choose(path, connections, wanted_topic, types, what):
    """The topic to read: the one named, else the one of ``types`` with the most messages (None: none)."""
    topics = {}
    for connection in connections:
        topics.setdefault(connection.topic, [connection.msgtype, 0])
        topics[connection.topic][1] += connection.msgcount
    if wanted_topic is not None:
        if wanted_topic not in topics:
            raise FitError('%s: no topic %s (topics: %s)' % (path, wanted_topic, ', '.join(sorted(topics)) or 'none'))
        if topics[wanted_topic][0] not in types:
            raise FitError('%s: topic %s is %s, not %s' % (path, wanted_topic, topics[wanted_topic][0],
                                                            ' or '.join(types)))
        return wanted_topic, topics[wanted_topic][0]
    found = [(count, topic, msgtype) for topic, (msgtype, count) in topics.items() if msgtype in types and count]
    if not found:
        return None, None
    if what == 'motion':   # the commanded speed (cmd_vel) before a measured one
        found.sort(key=lambda item: (item[2] == 'nav_msgs/msg/Odometry', 'cmd_vel' not in item[1], -item[0]))
    else:
        found.sort(key=lambda item: -item[0])
    return found[0][1], found[0][2]


def _messages(path, reader, battery_topic, motion_topic):
    connections = list(reader.connections)
    if not connections or sum(c.msgcount for c in connections) == 0:
        raise FitError('%s: the bag is empty (no messages)' % path)
    topic, _ = _choose(path, connections, battery_topic, (BATTERY_TYPE,), 'battery')
    if topic is None:
        raise FitError('%s: no sensor_msgs/BatteryState topic (topics: %s); name one with --battery-topic'
                       % (path, ', '.join(sorted({'%s [%s]' % (c.topic, c.msgtype) for c in connections}))))
    motion, motion_type = _choose(path, connections, motion_topic, MOTION_TYPES, 'motion')
    log = RawLog(name=str(path), source='battery %s' % topic + (', motion %s (%s)' % (motion, motion_type)
                                                                  if motion else ', no motion topic'))
    if motion:
        log.motion_time_s, log.linear_mps, log.angular_radps = [], [], []
    chosen = [c for c in connections if c.topic in (topic, motion)]
    try:
        for connection, stamp_ns, data in reader.messages(connections=chosen):
            message = reader.deserialize(data, connection.msgtype)
            _take(log, connection.topic == topic, connection.msgtype, message, stamp_ns * 1e-9)
    except FitError:
        raise
    except Exception as error:
        raise FitError('%s: cannot read the bag\'s messages: %s' % (path, ' '.join(str(error).split())[:200]
                                                                     or type(error).__name__)) from None
    return log


def _stamp(message, received_s):
    """The header's stamp (the sensor's time) when set, else when the bag received it, s."""
    header = getattr(message, 'header', None)
    if header is not None:
        stamp = header.stamp
        seconds = getattr(stamp, 'sec', None)
        if seconds is None:   # Debian's rosbag: rospy.Time
            seconds, nanoseconds = stamp.secs, stamp.nsecs
        else:
            nanoseconds = stamp.nanosec
        if seconds or nanoseconds:
            return seconds + nanoseconds * 1e-9
    return received_s


def _take(log, is_battery, msgtype, message, received_s):
    if is_battery:
        log.time_s.append(_stamp(message, received_s))
        log.voltage_v.append(float(message.voltage))
        log.current_a.append(float(message.current))
        log.temperature_c.append(float(message.temperature))
        log.percentage.append(float(message.percentage))
        cells = [float(v) for v in getattr(message, 'cell_voltage', ()) if math.isfinite(float(v)) and v > 0]
        if cells:
            log.cell_count = max(log.cell_count, len(cells))
        log.cell_sum_v.append(sum(cells) if cells else math.nan)
        return
    if msgtype.endswith('Odometry'):
        twist = message.twist.twist
    elif msgtype.endswith('TwistStamped'):
        twist = message.twist
    else:
        twist = message
    log.motion_time_s.append(_stamp(message, received_s) if msgtype.endswith(('Odometry', 'Stamped'))
                             else received_s)
    log.linear_mps.append(abs(float(twist.linear.x)))
    log.angular_radps.append(abs(float(twist.angular.z)))


class _RosbagConnection:
    def __init__(self, topic, msgtype, msgcount):
        self.topic, self.msgtype, self.msgcount = topic, msgtype, msgcount


def _read_ros1_with_rosbag(path, battery_topic, motion_topic):
    """A ROS 1 bag through Debian's rosbag (python3-rosbag), when rosbags is not installed."""
    try:
        import rosbag
    except ImportError:
        raise FitError('%s: reading a bag needs the Python library rosbags (pip install rosbags, or run '
                       'tools/install_dependencies.sh) or, for a ROS 1 bag, python3-rosbag' % path) from None
    try:
        bag = rosbag.Bag(str(path))
    except Exception as error:
        raise FitError('%s: cannot read the bag: %s' % (path, ' '.join(str(error).split()))) from None
    with bag:
        info = bag.get_type_and_topic_info().topics
        connections = [_RosbagConnection(topic, _ros2_name(item.msg_type), item.message_count)
                       for topic, item in info.items()]

        class _Reader:
            @staticmethod
            def messages(connections):
                names = {c.topic: c for c in connections}
                for topic, message, stamp in bag.read_messages(topics=list(names)):
                    yield names[topic], stamp.to_nsec(), message

            @staticmethod
            def deserialize(message, _msgtype):
                return message

        _Reader.connections = connections
        return _messages(path, _Reader, battery_topic, motion_topic)


def _ros2_name(ros1_type):
    """'sensor_msgs/BatteryState' -> 'sensor_msgs/msg/BatteryState' (the names rosbags uses)."""
    package, _, name = ros1_type.partition('/')
    return '%s/msg/%s' % (package, name)
