"""ROS 2: a robot that docks when low, as separate processes (demo.launch's ROS 2 twin; ``battery_demo`` runs
the same in one process): sim.launch.py on sim_clock, fake_base, the dock contact, the cut-off gate and
patrol_and_dock, every node on use_sim_time.

    patrol_and_dock -> cmd_vel_nav -> battery_cmd_vel_gate -> cmd_vel -> fake_base (and the battery's motion load)
    fake_base -> odom -> battery_dock_contact -> charger_contact -> battery (charger)

    ros2 launch battery_simulator demo.launch.py [speed:=240] [dashboard:=true]
"""
import os

from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, IncludeLaunchDescription, OpaqueFunction
from launch.launch_description_sources import PythonLaunchDescriptionSource
from launch_ros.actions import Node

from battery_simulator.robot.demo_settings import CLOCK_PACE_ON, CLOCK_WAIT_FOR as WAIT_FOR, START_X_M, \
    launch_default

HERE = os.path.dirname(os.path.abspath(__file__))
#: the demo's arguments; the defaults of battery_demo's settings are robot/demo_settings.py's
ARGUMENTS = (
    ('namespace', '', 'Namespace of the robot; empty: the root.'),
    ('speed', launch_default('speed'), 'The whole demo runs on sim_clock this many times as fast as wall time.'),
    ('tick_hz', launch_default('tick_hz'), 'sim_clock ticks per wall second (every node handles each tick).'),
    ('initial_percentage', launch_default('initial_percentage'), 'Battery level at start, %.'),
    ('gauge', launch_default('gauge'), 'ideal: the robot reads the truth; realistic: config/battery_realistic.yaml; '
     'impedance_track, modelgauge: a learning gauge (config/battery_impedance_track.yaml, battery_modelgauge.yaml) '
     'and the robot rests on the dock once full.'),
    ('config', launch_default('config'), 'Battery parameters (empty: by gauge).'),
    ('rate', launch_default('rate'), 'battery_status rate, Hz.'),
    ('low_percentage', launch_default('low_percentage'), 'The robot heads for the dock below this fraction.'),
    ('robot_speed', launch_default('robot_speed'), "The robot's cruising speed, m/s."),
    ('dock_x', launch_default('dock_x'), 'The dock, x (m).'),
    ('dock_y', launch_default('dock_y'), 'The dock, y (m).'),
    ('dashboard', 'false', 'true: also the live dashboard (dashboard.launch.py).'),
    ('dashboard_port', '8090', 'With dashboard: its TCP port.'),
)
#: ROS time starts once every node of the demo is up: a slow start costs no battery
CLOCK_WAIT_FOR = ','.join(WAIT_FOR)

def config_path(values):
    """The battery config: the config argument, or the gauge's (robot/demo_gauges.py)."""
    if values['config']:
        return values['config']
    from ament_index_python.packages import get_package_share_directory
    from battery_simulator.robot.demo_gauges import GAUGE_CONFIGS
    return os.path.join(get_package_share_directory('battery_simulator'), 'config',
                        GAUGE_CONFIGS.get(values['gauge'], 'battery.yaml'))


def _actions(context):
    from battery_simulator.robot.demo_gauges import rest_on_dock_s
    values = context.launch_configurations
    ns = values['namespace']
    actions = [IncludeLaunchDescription(PythonLaunchDescriptionSource(os.path.join(HERE, 'sim.launch.py')),
                                        launch_arguments={
        'namespace': ns, 'speed': values['speed'], 'tick_hz': values['tick_hz'], 'clock_wait_for': CLOCK_WAIT_FOR,
        'clock_pace_on': ','.join(CLOCK_PACE_ON),
        'initial_percentage': values['initial_percentage'], 'config': config_path(values), 'rate': values['rate'],
        'low_percentage': values['low_percentage']}.items())]
    if values['dashboard'].lower() in ('true', '1'):
        actions.append(IncludeLaunchDescription(
            PythonLaunchDescriptionSource(os.path.join(HERE, 'dashboard.launch.py')),
            launch_arguments={'port': values['dashboard_port']}.items()))
    dock = {'dock_x': float(values['dock_x']), 'dock_y': float(values['dock_y'])}
    use_sim_time = {'use_sim_time': True}
    actions += [
        # off the dock: a robot that starts on it would charge at once
        Node(package='battery_simulator', executable='fake_base', name='fake_base', namespace=ns, output='screen',
             parameters=[{'x': START_X_M, **use_sim_time}]),
        Node(package='battery_simulator', executable='battery_cmd_vel_gate', name='battery_cmd_vel_gate',
             namespace=ns, output='screen', parameters=[use_sim_time],
             remappings=[('cmd_vel_in', 'cmd_vel_nav'), ('cmd_vel_out', 'cmd_vel')]),
        Node(package='battery_simulator', executable='battery_dock_contact', name='battery_dock_contact',
             namespace=ns, output='screen', parameters=[{**dock, **use_sim_time}]),
        Node(package='battery_simulator', executable='patrol_and_dock', name='patrol_and_dock', namespace=ns,
             output='screen', remappings=[('cmd_vel', 'cmd_vel_nav')],
             parameters=[{'speed': float(values['robot_speed']), **dock, **use_sim_time,
                          'rest_on_dock': rest_on_dock_s(values['gauge'])}]),
    ]
    return actions


def generate_launch_description():
    return LaunchDescription([DeclareLaunchArgument(name, default_value=default, description=text)
                              for name, default, text in ARGUMENTS] + [OpaqueFunction(function=_actions)])
