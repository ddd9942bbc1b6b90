"""Robot logs made with this simulator for the battery_fit tests: the core model driven by a cmd_vel at
10 Hz, BatteryState sampled at 1 Hz with the sensor's noise, written as a CSV, a ROS 1 bag or a ROS 2 bag
(MCAP or sqlite3) with rosbags."""
import csv
import math
import random
from dataclasses import dataclass

import numpy

from battery_simulator.core.battery_model import BatteryModel, Mode
from battery_simulator.core.parameters import from_mapping

#: a robot unlike any preset: 5S3P of 3.2 Ah cells, other resistances, loads and motion
ROBOT = {'preset': 'lg_hg2_cell', 'name': 'test_robot', 'cells_series': 5, 'cells_parallel': 3,
         'cell_capacity_ah': 3.2, 'r0_ohm': 0.026, 'r1_ohm': 0.021, 'r_fast_ohm': 0.011,
         'load_current_a': 0.9, 'drive_power_w_per_mps': 85.0, 'turn_power_w_per_radps': 12.0,
         'charge_current_a': 4.0}
VOLTAGE_NOISE_V, CURRENT_NOISE_A = 0.010, 0.020


@dataclass
class Sample:
    time_s: float
    voltage_v: float
    current_a: float
    temperature_c: float
    percentage: float


def robot_params(overrides=None):
    return from_mapping(dict(ROBOT, **(overrides or {})), origin='test robot')


def simulate(params, duration_s=5400.0, seed=1, charge_at_s=None, rest_s=300.0, soc=1.0):
    """(battery samples at 1 Hz, cmd_vel samples at 10 Hz as (time, linear x, angular z)).

    A rest first, then drives of 20-120 s at random speeds with stops between; from ``charge_at_s`` on
    the robot stands on its charger (CC-CV)."""
    rng = random.Random(seed)
    model = BatteryModel(params, state_of_charge=soc, mode=Mode.IDLE)
    samples, commands = [], []
    speed = turn = 0.0
    segment_end = rest_s
    step = 0.1
    for tick in range(int(duration_s / step) + 1):
        now = tick * step
        charging = charge_at_s is not None and now >= charge_at_s
        if now >= segment_end and not charging:
            if speed or turn or rng.random() < 0.3:
                speed, turn = (0.0, 0.0) if rng.random() < 0.4 else (rng.uniform(0.2, 1.2), rng.uniform(0.0, 1.0))
            else:
                speed, turn = rng.uniform(0.2, 1.2), rng.uniform(0.0, 1.0)
            segment_end = now + rng.uniform(20.0, 120.0)
        if charging:
            speed = turn = 0.0
        if tick % 10 == 0:
            record(samples, now, model, rng)
        if now >= rest_s or charging:
            commands.append((now, speed, turn))
        wanted = Mode.CHARGE if charging else (Mode.DISCHARGE if now >= rest_s else Mode.IDLE)
        model.set_mode(wanted)
        model.set_extra_load('motion', power_w=params.motion_power_w(speed, turn))
        model.step(step)
    return samples, commands


def record(samples, now, model, rng):
    snapshot = model.snapshot()
    samples.append(Sample(now, snapshot.voltage_v + rng.gauss(0.0, VOLTAGE_NOISE_V),
                          snapshot.current_a + rng.gauss(0.0, CURRENT_NOISE_A), snapshot.temperature_c,
                          snapshot.percentage / 100.0))


def write_csv(path, samples, commands=None, invert_current=False, percent=False):
    motion = _motion_at(samples, commands) if commands else None
    with open(path, 'w', newline='') as stream:
        writer = csv.writer(stream)
        writer.writerow(['time', 'voltage', 'current', 'temperature', 'percentage']
                        + (['linear_x', 'angular_z'] if motion else []))
        for k, s in enumerate(samples):
            row = ['%.3f' % s.time_s, '%.5f' % s.voltage_v, '%.5f' % (-s.current_a if invert_current else s.current_a),
                   '%.3f' % s.temperature_c, '%.5f' % (s.percentage * (100.0 if percent else 1.0))]
            writer.writerow(row + (['%.4f' % motion[k][0], '%.4f' % motion[k][1]] if motion else []))


def _motion_at(samples, commands):
    """The command in force at each battery sample (for a CSV's linear_x / angular_z)."""
    out, j = [], 0
    for s in samples:
        while j + 1 < len(commands) and commands[j + 1][0] <= s.time_s + 1e-9:
            j += 1
        out.append(commands[j][1:] if commands and commands[j][0] <= s.time_s + 1e-9 else (0.0, 0.0))
    return out


def write_bag(path, samples, commands, storage, start_s=1.7e9):
    """A bag with /battery_status (sensor_msgs/BatteryState) and /cmd_vel (geometry_msgs/Twist):
    storage 'ros1', 'mcap' or 'sqlite3'."""
    from battery_simulator.core.fit.log_reader import import_rosbags
    import_rosbags()
    from rosbags.typesys import Stores, get_typestore
    if storage == 'ros1':
        from rosbags.rosbag1 import Writer
        typestore = get_typestore(Stores.ROS1_NOETIC)
        writer = Writer(path)
        serialize = typestore.serialize_ros1
    else:
        from rosbags.rosbag2 import StoragePlugin, Writer
        typestore = get_typestore(Stores.ROS2_HUMBLE)
        writer = Writer(path, version=9, storage_plugin=StoragePlugin.MCAP if storage == 'mcap'
                        else StoragePlugin.SQLITE3)
        serialize = typestore.serialize_cdr
    types = typestore.types
    BatteryState, Header, Time = (types['sensor_msgs/msg/BatteryState'], types['std_msgs/msg/Header'],
                                  types['builtin_interfaces/msg/Time'])
    Twist, Vector3 = types['geometry_msgs/msg/Twist'], types['geometry_msgs/msg/Vector3']
    events = [(s.time_s, 0, s) for s in samples] + [(c[0], 1, c) for c in commands]
    events.sort(key=lambda e: (e[0], e[1]))
    with writer:
        battery = writer.add_connection('/battery_status', BatteryState.__msgtype__, typestore=typestore)
        cmd_vel = writer.add_connection('/cmd_vel', Twist.__msgtype__, typestore=typestore)
        for time_s, kind, item in events:
            stamp_ns = int(round((start_s + time_s) * 1e9))
            if kind == 0:
                stamp = Time(sec=stamp_ns // 10 ** 9, nanosec=stamp_ns % 10 ** 9)
                header = Header(seq=0, stamp=stamp, frame_id='') if storage == 'ros1' else \
                    Header(stamp=stamp, frame_id='')
                message = BatteryState(
                    header=header, voltage=item.voltage_v, temperature=item.temperature_c, current=item.current_a,
                    charge=math.nan, capacity=math.nan, design_capacity=math.nan, percentage=item.percentage,
                    power_supply_status=2, power_supply_health=1, power_supply_technology=2, present=True,
                    cell_voltage=numpy.zeros(0, dtype=numpy.float32),
                    cell_temperature=numpy.zeros(0, dtype=numpy.float32), location='base', serial_number='')
                writer.write(battery, stamp_ns, serialize(message, BatteryState.__msgtype__))
            else:
                message = Twist(linear=Vector3(x=item[1], y=0.0, z=0.0), angular=Vector3(x=0.0, y=0.0, z=item[2]))
                writer.write(cmd_vel, stamp_ns, serialize(message, Twist.__msgtype__))
