"""Robot logs made with this simulator for the battery_fit tests: the core model driven by a cmd_vel at
10 Hz, BatteryState sampled at 1 Hz with the sensor's noise, written as a CSV, a ROS 1 bag or a ROS 2 bag
(MCAP or sqlite3) with rosbags."""
import csv
import math
import os
import random
from dataclasses import dataclass

import numpy

from battery_simulator.core.battery_model import BatteryModel
from battery_simulator.core.battery_states import Mode
from battery_simulator.core.config_files import from_mapping

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


def simulate(params, duration_s=5400.0, seed=1, charge_at_s=None, rest_s=300.0, soc=1.0, until_soc=None):
    """(battery samples at 1 Hz, cmd_vel samples at 10 Hz as (time, linear x, angular z)).

    A rest first, then drives of 20-120 s at random speeds with stops between; from ``charge_at_s`` on
    the robot stands on its charger (CC-CV); the log ends early where the SOC falls to ``until_soc``."""
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
            if until_soc is not None and model.state_of_charge <= until_soc:
                break
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


# -- packs that are not LG HG2 (issue 36's vehicle case) --------------------------------------------------

#: An NMC811 cell's OCV (the LG M50, 5 Ah): the full cell's U = U_pos(y) - U_neg(x) from the electrode fits of
#: Chen, C.-H.; Brosa Planella, F.; O'Regan, K.; Gastol, D.; Widanage, W. D.; Kendrick, E. (2020),
#: "Development of Experimental Techniques for Parameterization of Multi-scale Lithium-ion Battery Models",
#: J. Electrochem. Soc. 167, 080534, doi:10.1149/1945-7111/ab9050 (NMC811 and graphite-SiOx open-circuit
#: potentials as tanh fits; stoichiometries x 0.0279-0.9014, y 0.9084-0.2661 from 0 to 100 % SOC), evaluated
#: at these SOC points (see nmc811_ocv below). It lies up to 37 mV below LG HG2's, with other bends.
NMC811_SOC = (0.0, 0.025, 0.05, 0.075, 0.1, 0.15, 0.2, 0.25, 0.3, 0.35, 0.4, 0.45, 0.5, 0.55, 0.6, 0.65, 0.7,
              0.75, 0.8, 0.85, 0.9, 0.95, 0.975, 1.0)


def nmc811_ocv(soc):
    """Chen et al. 2020's full-cell OCV of the LG M50 (NMC811 / graphite-SiOx) at ``soc`` (0..1), V."""
    soc = numpy.asarray(soc, dtype=float)
    x, y = 0.0279 + soc * (0.9014 - 0.0279), 0.9084 + soc * (0.2661 - 0.9084)
    tanh = numpy.tanh
    positive = (-0.8090 * y + 4.4875 - 0.0428 * tanh(18.5138 * (y - 0.5542)) - 17.7326 * tanh(15.7890 * (y - 0.3117))
                + 17.5842 * tanh(15.9308 * (y - 0.3120)))
    negative = (1.9793 * numpy.exp(-39.3631 * x) + 0.2482 - 0.0909 * tanh(29.8538 * (x - 0.1234))
                - 0.04478 * tanh(14.9159 * (x - 0.2769)) - 0.0205 * tanh(30.4444 * (x - 0.6103)))
    return positive - negative


#: A made-up chemistry for a 24S4P robot pack: flatter in the middle and steeper at the ends than LG HG2 (its
#: OCV plus a 70 mV wave), as a pack of unknown cells can be.
MADE_UP_SOC = tuple(k / 20.0 for k in range(21))


def made_up_ocv(soc):
    hg2 = from_mapping({'preset': 'lg_hg2_cell'})
    soc = numpy.asarray(soc, dtype=float)
    return numpy.interp(soc, hg2.ocv_soc, hg2.ocv_voltage_v) + 0.07 * numpy.sin(2.0 * math.pi * soc) - 0.03 * soc


def _tables(soc_points, ocv):
    volts = [round(float(v), 4) for v in ocv(soc_points)]
    # no charge branch, no SOC factor tables: the foreign cell's resistances do not follow LG HG2's
    return {'ocv_soc': list(soc_points), 'ocv_voltage_v': volts, 'resistance_soc': [], 'r0_soc_factor': [],
            'r1_soc_factor': [], 'r_fast_soc_factor': [], 'r0_charge_factor': 1.0, 'r1_charge_factor': 1.0,
            'r_fast_charge_factor': 1.0, 'cell_cutoff_voltage_v': volts[0], 'cell_charge_voltage_v': volts[-1]}


#: A vehicle: 96S1P of 60 Ah NMC811 cells (about 350 V, 21 kWh), resistances of such a cell (0.9 mOhm ohmic,
#: a 40 s and a 4 s RC pair), its cell's heat.
VEHICLE = dict({'preset': 'lg_hg2_cell', 'name': 'test_vehicle', 'cells_series': 96, 'cells_parallel': 1,
                'cell_capacity_ah': 60.0, 'r0_ohm': 0.0009, 'r1_ohm': 0.0006, 'tau1_s': 40.0,
                'r_fast_ohm': 0.0003, 'tau_fast_s': 4.0, 'load_current_a': 0.0, 'cell_heat_capacity_j_per_k': 1000.0,
                'cell_heat_transfer_w_per_k': 1.5, 'cell_max_discharge_current_a': 400.0,
                'cell_max_charge_current_a': 200.0, 'charge_current_a': 30.0, 'hysteresis_ah': 0.5},
               **_tables(NMC811_SOC, nmc811_ocv))
#: the vehicle's BMS: voltage sigma 0.1 V (pack), current sigma 0.2 A, at 10 Hz
VEHICLE_VOLTAGE_NOISE_V, VEHICLE_CURRENT_NOISE_A, VEHICLE_RATE_HZ = 0.1, 0.2, 10.0

#: The 24S4P robot pack of a made-up chemistry (3.0 Ah cells), a heavier robot than ROBOT.
FOREIGN_ROBOT = dict({'preset': 'lg_hg2_cell', 'name': 'test_foreign_robot', 'cells_series': 24,
                      'cells_parallel': 4, 'cell_capacity_ah': 3.0, 'r0_ohm': 0.03, 'r1_ohm': 0.02, 'tau1_s': 300.0,
                      'r_fast_ohm': 0.01, 'tau_fast_s': 20.0, 'load_current_a': 2.0, 'drive_power_w_per_mps': 500.0,
                      'turn_power_w_per_radps': 80.0, 'charge_current_a': 6.0},
                     **_tables(MADE_UP_SOC, made_up_ocv))


def vehicle_params():
    return from_mapping(VEHICLE, origin='test vehicle')


def foreign_robot_params():
    return from_mapping(FOREIGN_ROBOT, origin='test foreign robot')


def drive_power_w(rng, duration_s, rate_hz=VEHICLE_RATE_HZ):
    """A car's battery power (W, positive = into the battery) at ``rate_hz``: urban stretches (accelerate to
    30-60 km/h, cruise, brake with regeneration, stand 5-40 s) and highway stretches (90-130 km/h with
    overtaking), 1800 kg, rolling 0.01, CdA 0.65 m2, drive 90 % up to 100 kW, regeneration up to 50 kW, 800 W
    auxiliaries."""
    dt = 1.0 / rate_hz
    count = int(duration_s * rate_hz) + 1
    speed, power = 0.0, numpy.empty(count)
    plan, k = [], 0
    while len(plan) < count:
        if rng.random() < 0.5:   # an urban stretch of 3-6 min
            end = len(plan) + int(rng.uniform(180, 360) * rate_hz)
            while len(plan) < end:
                target = rng.uniform(30, 60) / 3.6
                plan += [('accelerate', target, rng.uniform(1.0, 2.5))] * int(rng.uniform(15, 45) * rate_hz)
                plan += [('brake', 0.0, rng.uniform(1.0, 3.0))] * int(rng.uniform(8, 20) * rate_hz)
                plan += [('stand', 0.0, 0.0)] * int(rng.uniform(5, 40) * rate_hz)
        else:                    # a highway stretch of 4-8 min
            end = len(plan) + int(rng.uniform(240, 480) * rate_hz)
            while len(plan) < end:
                plan += [('accelerate', rng.uniform(90, 130) / 3.6, rng.uniform(0.5, 2.0))] * int(
                    rng.uniform(20, 90) * rate_hz)
    for k in range(count):
        action, target, rate = plan[k]
        if action == 'accelerate':
            accel = min(rate, (target - speed) / dt) if speed < target else max(-0.8, (target - speed) / dt)
        elif action == 'brake':
            accel = max(-rate, -speed / dt)
        else:
            accel = -speed / dt
        speed = max(0.0, speed + accel * dt)
        force = 1800.0 * accel + 1800.0 * 9.81 * 0.01 * (speed > 0) + 0.5 * 1.2 * 0.65 * speed ** 2
        wheel = force * speed
        battery = min(100000.0, wheel / 0.9) if wheel > 0 else max(-50000.0, 0.6 * wheel)
        power[k] = -(battery + 800.0)
    return power


def simulate_vehicle(params, soc_from, soc_to, seed, rate_hz=VEHICLE_RATE_HZ):
    """A drive at ``rate_hz`` from SOC ``soc_from`` until ``soc_to``: samples (with the BMS's noise) and the
    true SOC at each."""
    rng = random.Random(seed)
    model = BatteryModel(params, state_of_charge=soc_from, mode=Mode.DISCHARGE)
    power = drive_power_w(rng, 4.0 * 3600.0, rate_hz)
    dt = 1.0 / rate_hz
    samples, socs = [], []
    for k, p in enumerate(power):
        snapshot = model.snapshot()
        samples.append(Sample(k * dt, snapshot.voltage_v + rng.gauss(0.0, VEHICLE_VOLTAGE_NOISE_V),
                              snapshot.current_a + rng.gauss(0.0, VEHICLE_CURRENT_NOISE_A), snapshot.temperature_c,
                              snapshot.percentage / 100.0))
        socs.append(model.state_of_charge)
        if model.state_of_charge <= soc_to:
            break
        model.step(dt, power_w=p)
    return samples, socs


def vehicle_logs(directory, params=None, spans=((0.9, 0.5, 21), (0.7, 0.3, 22)), rate_hz=VEHICLE_RATE_HZ):
    """Two drives of the vehicle as CSVs (overlapping SOC ranges: the default hold-out of the first lies within
    the range the second's fitted part covers): [(path, true SOC per sample)]."""
    params = params or vehicle_params()
    out = []
    for index, (soc_from, soc_to, seed) in enumerate(spans):
        samples, socs = simulate_vehicle(params, soc_from, soc_to, seed, rate_hz)
        path = os.path.join(str(directory), 'drive%d.csv' % (index + 1))
        write_csv(path, samples)
        out.append((path, numpy.asarray(socs)))
    return out


def foreign_robot_logs(directory, params=None, spans=((0.95, 0.55, 31), (0.75, 0.35, 32))):
    """Two logs of the 24S4P robot (BatteryState at 1 Hz, cmd_vel at 10 Hz) between these SOCs, as CSVs:
    [(path, true SOC per sample)]."""
    params = params or foreign_robot_params()
    out = []
    for index, (soc_from, soc_to, seed) in enumerate(spans):
        samples, commands = simulate(params, duration_s=4.0 * 3600.0, seed=seed, soc=soc_from, rest_s=120.0,
                                     until_soc=soc_to)
        path = os.path.join(str(directory), 'robot%d.csv' % (index + 1))
        write_csv(path, samples, commands)
        out.append((path, numpy.asarray([s.percentage for s in samples])))
    return out


# -- measured logs: fit the first part, score the rest through battery_replay ------------------------------

def replayed_voltage(config_path, log_csv, soc):
    """(time, logged voltage, replayed voltage, replayed temperature, logged temperature or None) of a CSV log
    replayed with ``config_path`` from ``soc`` through battery_replay's function (the log's own current)."""
    from battery_simulator.core.fit.log_reader import read_log
    from battery_simulator.core.config_files import load_yaml
    from battery_simulator.core.replay import replay
    raw = read_log(log_csv)
    t = numpy.asarray(raw.time_s, dtype=float)
    keep = numpy.isfinite(t) & numpy.isfinite(raw.voltage_v) & numpy.isfinite(raw.current_a)
    t = t[keep] - t[keep][0]
    v = numpy.asarray(raw.voltage_v)[keep]
    i = numpy.asarray(raw.current_a)[keep]
    temp = numpy.asarray(raw.temperature_c, dtype=float)[keep]
    rows = list(replay(load_yaml(config_path), [(float(a), 'current', float(b)) for a, b in zip(t, i)],
                       state_of_charge=soc))
    return (t, v, numpy.array([float(r[1]) for r in rows]), numpy.array([float(r[4]) for r in rows]),
            temp if numpy.isfinite(temp).all() else None)


def fit_and_score(log_csv, directory, cells, holdout=0.4, extra=(), predict=()):
    """Fit ``log_csv`` with battery_fit holding out its last ``holdout``; replay it (and each of ``predict``,
    from the SOC its own first voltage gives) with the config; the figures in mV per true series cell."""
    import io
    import re
    from battery_simulator.cli import fit as fit_cli
    from battery_simulator.core.config_files import load_yaml
    output = os.path.join(directory, os.path.basename(str(log_csv)) + '.yaml')
    if os.path.exists(output):
        os.remove(output)
    args = fit_cli.parse_arguments([str(log_csv), '-o', output, '--holdout', str(holdout)] + list(extra))
    report = io.StringIO()
    fit_cli.run(args, stdout=report)
    text = report.getvalue()
    soc = float(re.findall(r'--soc ([0-9.]+)', text)[0])
    params = load_yaml(output)
    t, v, model, model_t, logged_t = replayed_voltage(output, log_csv, soc)
    held = t > t[-1] * (1.0 - holdout)
    out = {'report': text, 'config': output, 'cells_series': params.cells_series,
           'capacity_ah': params.design_capacity_ah,
           'fitted_mv': 1000.0 * float(numpy.sqrt(numpy.mean((model - v)[~held] ** 2))) / cells,
           'held_mv': 1000.0 * float(numpy.sqrt(numpy.mean((model - v)[held] ** 2))) / cells,
           'temperature_k': float(numpy.max(numpy.abs(model_t - logged_t))) if logged_t is not None else None,
           'predicted_mv': []}
    for other in predict:
        out['predicted_mv'].append(1000.0 * predicted_rmse(output, other) / cells)
    return out


def predicted_rmse(config_path, log_csv):
    """RMSE (pack V) of ``log_csv`` replayed whole with the config, from the SOC the logged percentage or
    (without one) the first voltage's OCV gives."""
    from battery_simulator.core.fit.log_reader import read_log
    from battery_simulator.core.config_files import load_yaml
    params = load_yaml(config_path)
    raw = read_log(log_csv)
    pct = numpy.asarray(raw.percentage, dtype=float)
    if numpy.isfinite(pct[:1]).all():
        soc = float(pct[0]) / (100.0 if numpy.nanmax(pct) > 1.5 else 1.0)
    else:
        cell = float(raw.voltage_v[0]) / params.cells_series
        soc = float(numpy.interp(cell, params.ocv_voltage_v, params.ocv_soc))
    t, v, model, _, _ = replayed_voltage(config_path, log_csv, soc)
    return float(numpy.sqrt(numpy.mean((model - v) ** 2)))


def preset_rmse(log_csv, preset_name, cells_series, cells_parallel, holdout=0.4):
    """mV per cell of the held-out part of ``log_csv`` replayed with the unfitted preset (as a pack of
    ``cells_series`` x ``cells_parallel``), from the SOC the logged percentage or the first voltage gives."""
    import tempfile
    import yaml
    from battery_simulator.core.fit.log_reader import read_log
    from battery_simulator.core.config_files import preset
    params = preset(preset_name)
    raw = read_log(log_csv)
    pct = numpy.asarray(raw.percentage, dtype=float)
    if numpy.isfinite(pct[:1]).all():
        soc = float(pct[0]) / (100.0 if numpy.nanmax(pct) > 1.5 else 1.0)
    else:
        soc = float(numpy.interp(float(raw.voltage_v[0]) / cells_series, params.ocv_voltage_v, params.ocv_soc))
    limit = max(abs(float(numpy.nanmin(raw.current_a))), abs(float(numpy.nanmax(raw.current_a)))) / cells_parallel
    with tempfile.NamedTemporaryFile('w', suffix='.yaml', delete=False) as stream:
        yaml.safe_dump({'preset': preset_name, 'cells_series': cells_series, 'cells_parallel': cells_parallel,
                        'charge_current_a': params.charge_current_a * cells_parallel,
                        'load_current_a': params.load_current_a * cells_parallel,
                        'cell_max_discharge_current_a': max(params.cell_max_discharge_current_a, 2 * limit),
                        'cell_max_charge_current_a': max(params.cell_max_charge_current_a, 2 * limit)}, stream)
    try:
        t, v, model, _, _ = replayed_voltage(stream.name, log_csv, soc)
    finally:
        os.remove(stream.name)
    held = t >= t[-1] * (1.0 - holdout)
    return 1000.0 * float(numpy.sqrt(numpy.mean((model - v)[held] ** 2))) / cells_series
