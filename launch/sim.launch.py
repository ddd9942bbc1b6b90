"""ROS 2: the simulated battery (sim.launch's ROS 2 twin): ``battery_sim`` (the nodes battery_simulator and
battery_state_pub in one process), and with ``speed`` the clock ``sim_clock`` with every node on it.

    ros2 launch battery_simulator sim.launch.py [speed:=60] [initial_percentage:=80] ...

Every name is relative: ``namespace:=robot1`` for one battery per robot.
"""
import os
import tempfile

from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, OpaqueFunction
from launch_ros.actions import Node

from battery_simulator.ros2.respawn import respawning_node

ARGUMENTS = (
    ('namespace', '', 'Namespace of the battery (e.g. robot1); empty: the root.'),
    ('time_scale', '22', 'Simulated seconds per wall second (ignored with speed).'),
    ('initial_percentage', '100', 'State of charge at start, 0-100 %.'),
    ('charging', 'false', 'Initial mode: true charges, false discharges.'),
    ('rate', '1.0', 'battery_status publication rate, Hz.'),
    ('config', '', 'YAML file of battery parameters (empty: the package config/battery.yaml).'),
    ('gauge_config', '', "A YAML file whose gauge section replaces the config's: a gauge preset "
     '(config/presets/gauge_impedance_track.yaml, gauge_modelgauge.yaml) with any pack. Empty: the config\'s.'),
    ('update_rate', '10', 'Model updates (and action feedback) per second, Hz.'),
    ('state_file', '', 'JSON file the state is saved to and resumed from (ageing across runs); empty: a file of '
                       "this launch's own, so that a respawned battery resumes (as ROS 1's does)."),
    ('low_percentage', '0.20', 'battery_low turns true below this fraction.'),
    ('critical_percentage', '0.05', 'battery_critical turns true below this fraction.'),
    ('hysteresis', '0.05', 'A low/critical event clears above its threshold plus this fraction.'),
    ('battery_state_topic', 'battery_state', 'The same BatteryState also on this topic, relative to the robot '
                                             '(opennav_docking reads battery_state). Empty: battery_status only.'),
    ('speed', '', 'Run on sim_clock this many times as fast as wall time (use_sim_time); empty: wall time.'),
    ('tick_hz', '1000', 'With speed: /clock ticks per wall second.'),
    ('clock_wait_for', '', 'With speed: topics (comma-separated) that must have a publisher before time runs.'),
    ('clock_pace_on', '', 'With speed: topics (comma-separated) each tick waits for a message on (at most 0.5 s '
                          "of wall time; demo.launch.py: the robot's cmd_vel)."),
)


def sim_nodes(values):
    """The Node actions of sim.launch.py for launch configuration ``values`` (strings)."""
    sim_time = values['speed'] != ''
    nodes = []
    if values['speed'] != '':
        clock = {'speed': float(values['speed']), 'tick_hz': float(values['tick_hz'])}
        wait_for = [topic.strip() for topic in values['clock_wait_for'].split(',') if topic.strip()]
        if wait_for:   # (a parameters file holds no empty list)
            clock['wait_for'] = wait_for
        pace_on = [topic.strip() for topic in values['clock_pace_on'].split(',') if topic.strip()]
        if pace_on:
            clock['pace_on'] = pace_on
        nodes.append(Node(package='battery_simulator', executable='sim_clock', name='sim_clock',
                          namespace=values['namespace'], output='screen', parameters=[clock]))
    battery = {
        'time_scale': float(values['time_scale']), 'initial_percentage': float(values['initial_percentage']),
        'charging': values['charging'].lower() in ('true', '1'), 'update_rate': float(values['update_rate']),
        'state_file': state_file(values), 'rate': float(values['rate']),
        'battery_state_topic': values['battery_state_topic'],
        'low_percentage': float(values['low_percentage']),
        'critical_percentage': float(values['critical_percentage']), 'hysteresis': float(values['hysteresis']),
        'use_sim_time': sim_time}
    if values['config']:
        battery['config'] = values['config']
    if values['gauge_config']:
        battery['gauge_config'] = values['gauge_config']
    # respawn: a crashed battery comes back and resumes from its state file; a start-up error (exit 2) ends the
    # launch with its one line instead
    nodes += respawning_node(delay_s=1.0, package='battery_simulator', executable='battery_sim',
                             namespace=values['namespace'], output='screen', parameters=[battery])
    return nodes


def state_file(values):
    """The state_file argument, or (empty) a file of this launch's own, so that a respawned battery resumes where
    it was, as ROS 1's does from ~saved_state; a new launch starts afresh."""
    if values['state_file']:
        return values['state_file']
    return os.path.join(tempfile.mkdtemp(prefix='battery_sim_launch_'), 'state.json')


def _nodes(context):
    return sim_nodes(context.launch_configurations)


def generate_launch_description():
    return LaunchDescription([DeclareLaunchArgument(name, default_value=default, description=text)
                              for name, default, text in ARGUMENTS] + [OpaqueFunction(function=_nodes)])
