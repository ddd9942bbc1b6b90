"""Issue 40 item 12: what a start or a late goal must refuse. ``config:=/etc/passwd`` printed 200 characters of
that file in its fatal line (now: the file named, its content never); a charge goal was accepted after "server
shutting down" (now rejected); battery_demo took ``robot_speed:=1e9`` and an unknown parameter silently (now
one line each, exit 2)."""
import pytest
from rclpy.action.server import GoalResponse
from rclpy.node import Node

from battery_simulator.core.config_files import default_config_path, load_yaml
from battery_simulator.ros2.action_server import BatterySimServer
from battery_simulator.ros2.battery_settings import make_battery
from battery_simulator.ros2.log import RobotLog
from ros2_probe import NodeProcess, Probe


def one_fatal_line(executable, *ros_args, timeout_s=30.0):
    process = NodeProcess(executable, *ros_args)
    code = process.wait(timeout_s)
    if code is None:
        process.stop()
    output = process.output()
    lines = [line for line in output.splitlines() if line.strip()]
    assert code == 2 and len(lines) == 1 and 'Traceback' not in output, 'exit %s:\n%s' % (code, output)
    return lines[0]


def test_a_config_that_is_not_one_is_named_never_printed(tmp_path):
    secret = tmp_path / 'passwd'
    secret.write_text(''.join('user%d:x:%d:%d:secret%d:/home/user%d:/bin/bash\n' % ((k,) * 5) for k in range(40)))
    line = one_fatal_line('battery_sim', '-r', '__ns:=/badconfig', '-p', 'config:=' + str(secret))
    assert str(secret) in line and 'config' in line
    assert 'secret' not in line.replace(str(tmp_path), '') and '/bin/bash' not in line, line


@pytest.mark.parametrize('argument, named', [('robot_speed:=1e9', 'robot_speed'), ('spede:=240', 'spede')])
def test_battery_demo_refuses_a_bad_or_unknown_parameter(argument, named):
    line = one_fatal_line('battery_demo', '-r', '__ns:=/baddemo', '-p', argument)
    assert named in line and 'battery_demo' in line, line


def test_a_goal_after_server_shutting_down_is_rejected():
    probe = Probe('late_goal_probe')   # rclpy up in this process
    node = Node('late_goal_server', namespace='/late_goal')
    try:
        settings = {'initial_percentage': 50.0, 'max_time_jump': 60.0}
        battery = make_battery(node, settings, load_yaml(default_config_path()), False, RobotLog(node.get_logger()))
        server = BatterySimServer(node, battery, '', RobotLog(node.get_logger()))
        assert server._goal_response(None) == GoalResponse.ACCEPT
        server.finish()   # SIGINT or SIGTERM: goals ended, state saved, the last results on their way
        assert server._goal_response(None) == GoalResponse.REJECT, 'a goal accepted after "server shutting down"'
    finally:
        node.destroy_node()
        probe.close()


@pytest.mark.parametrize('ros_args, named', [
    (('-p', 'time_scale:=-1.0'), 'time_scale'),
    (('-p', 'initial_percentage:=120.0'), 'initial_percentage'),
    (('-p', 'config:=/nonexistent.yaml'), 'config'),
    (('-p', 'critical_percentage:=0.5'), 'critical_percentage'),
    (('-p', 'load_current_a:=-3.0'), 'load_current_a'),
])
def test_bad_startup_value_ends_with_one_line(ros_args, named):
    process = NodeProcess('battery_sim', '-r', '__ns:=/bad', *ros_args)
    try:
        status = process.wait(20.0)
        assert status not in (None, 0), 'a bad %s ends the process non-zero (%r)' % (named, status)
        fatal = [line for line in process.output().splitlines() if 'invalid' in line]
        assert len(fatal) == 1 and named in fatal[0], process.output()
        assert 'Traceback' not in process.output(), process.output()
    finally:
        process.stop()
