"""ROS 2: N simulated batteries robot0 ... robot<N-1> (fleet.launch's ROS 2 twin), hosted by ``hosts``
battery_fleet processes that split them evenly (host k: its own first robot and count; host 0 is
/battery_fleet, host k > 0 /battery_fleet_k, as fleet.launch names them; every robot is /robotN whatever the
split). Levels are staggered: 100 %, 95 %, ... wrapping
at 20 %. With ``speed`` every host runs on sim_clock.

    ros2 launch battery_simulator fleet.launch.py n:=100 [hosts:=2] [speed:=60] [dashboard:=true]
"""
import os
import tempfile

from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, IncludeLaunchDescription, OpaqueFunction
from launch.launch_description_sources import PythonLaunchDescriptionSource
from launch_ros.actions import Node

from battery_simulator.ros2.respawn import respawning_node

HERE = os.path.dirname(os.path.abspath(__file__))
ARGUMENTS = (
    ('n', '3', 'How many robots (1 to 10000).'),
    ('hosts', '1', 'How many host processes share them (1 to n); about 100 robots a host on ROS 2.'),
    ('time_scale', '22', 'Simulated seconds per wall second, for every robot.'),
    ('rate', '1.0', 'battery_status rate of each robot, Hz.'),
    ('update_rate', '2', 'Model updates (and action feedback) per second of each robot, Hz.'),
    ('config', '', 'Battery parameters of every robot (empty: the package config/battery.yaml).'),
    ('state_file', '', 'JSON file every robot\'s state is saved to and resumed from (host k > 0: name_k.json); '
                       'empty: files of this launch\'s own (a respawned host resumes; a new launch starts afresh).'),
    ('fleet_rate', '1.0', 'Rate of /battery_fleet/states (battery_simulator/BatteryFleetState), Hz.'),
    ('speed', '', 'Run every robot on sim_clock this many times as fast as wall time; empty: wall time.'),
    ('dashboard', 'false', 'true: also the live dashboard (dashboard.launch.py).'),
    ('dashboard_port', '8090', 'With dashboard: its TCP port.'),
)


def shares(n, hosts):
    """[(first, count)] of each host: n robots split evenly over the hosts."""
    return [(n * k // hosts, n * (k + 1) // hosts - n * k // hosts) for k in range(hosts)]


def host_state_file(path, host, hosts):
    """Host k's state file: ``path`` itself with one host, else ``path`` with ``_k`` before its extension (one
    state file per battery host: fleet_1.json, ...)."""
    if hosts == 1:
        return path
    stem, extension = os.path.splitext(path)
    return '%s_%d%s' % (stem, host, extension)


def _actions(context):
    values = context.launch_configurations
    n, hosts = int(values['n']), int(values['hosts'])
    if not 1 <= hosts <= n:
        raise ValueError('launch argument hosts = %d is invalid: must be in [1, n = %d]' % (hosts, n))
    sim_time = values['speed'] != ''
    actions = []
    if values['dashboard'].lower() in ('true', '1'):
        actions.append(IncludeLaunchDescription(
            PythonLaunchDescriptionSource(os.path.join(HERE, 'dashboard.launch.py')),
            launch_arguments={'port': values['dashboard_port']}.items()))
    if sim_time:
        actions.append(Node(package='battery_simulator', executable='sim_clock', name='sim_clock', output='screen',
                            parameters=[{'speed': float(values['speed'])}]))
    # empty: files of this launch's own, so that a respawned host's robots resume (as ROS 1's do from ~saved_states)
    own_state_file = values['state_file'] or os.path.join(tempfile.mkdtemp(prefix='battery_fleet_launch_'),
                                                          'fleet.json')
    for host, (first, count) in enumerate(shares(n, hosts)):
        parameters = {'robots': count, 'first': first, 'time_scale': float(values['time_scale']),
                      'rate': float(values['rate']), 'update_rate': float(values['update_rate']),
                      'fleet_rate': float(values['fleet_rate']), 'use_sim_time': sim_time}
        if values['config']:
            parameters['config'] = values['config']
        parameters['state_file'] = host_state_file(own_state_file, host, hosts)
        # respawn: a crashed host comes back (with state_file, every robot resumes); a start-up error (exit 2: a
        # bad argument, a robot another host serves) ends the launch with its one line instead
        actions += respawning_node(delay_s=1.0, package='battery_simulator', executable='battery_fleet',
                                   output='screen', name='battery_fleet' if host == 0 else 'battery_fleet_%d' % host,
                                   parameters=[parameters])
    return actions


def generate_launch_description():
    return LaunchDescription([DeclareLaunchArgument(name, default_value=default, description=text)
                              for name, default, text in ARGUMENTS] + [OpaqueFunction(function=_actions)])
