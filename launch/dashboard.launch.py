"""ROS 2: the live dashboard (dashboard.launch's ROS 2 twin): every sensor_msgs/msg/BatteryState on the
ROS 2 graph in a browser, at http://127.0.0.1:8090/ by default (docs/dashboard.md).

    ros2 launch battery_simulator dashboard.launch.py [port:=8091] [allow_control:=true]
"""
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, OpaqueFunction
from launch_ros.actions import Node

ARGUMENTS = (
    ('host', '127.0.0.1', 'Address to listen on; 0.0.0.0 opens it to the network (read docs/dashboard.md first).'),
    ('port', '8090', 'TCP port of the page.'),
    ('allow_control', 'false', 'true: buttons that call set_state, set_charging and inject_fault.'),
    ('history_s', '600', 'Span of the charts, s; a battery silent this long leaves the page.'),
    ('scan_period', '2', 'How often the graph is asked for new battery topics, s.'),
)


def _nodes(context):
    values = context.launch_configurations
    return [Node(package='battery_simulator', executable='battery_dashboard', name='battery_dashboard',
                 output='screen', parameters=[{
                     'host': values['host'], 'port': int(values['port']),
                     'allow_control': values['allow_control'].lower() in ('true', '1'),
                     'history_s': float(values['history_s']), 'scan_period': float(values['scan_period'])}])]


def generate_launch_description():
    return LaunchDescription([DeclareLaunchArgument(name, default_value=default, description=text)
                              for name, default, text in ARGUMENTS] + [OpaqueFunction(function=_nodes)])
