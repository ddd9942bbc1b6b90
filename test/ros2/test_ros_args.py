"""A --ros-args that rcl cannot parse (``-p name:=`` with no value) is one line naming it and exit 2, never
rclpy's RCLError traceback, for every ROS 2 executable."""
import pytest

from ros2_probe import NodeProcess

BAD = ('--ros-args', '-p', 'frame_id:=')


def run(executable, *args, timeout_s=30.0):
    process = NodeProcess(executable, args=args)
    code = process.wait(timeout_s)
    if code is None:
        process.stop()
        raise AssertionError('%s did not end within %g s:\n%s' % (executable, timeout_s, process.output()))
    return code, process.output()


@pytest.mark.parametrize('executable, args', [
    ('battery_doctor', ()), ('battery_sim_client', ('1',)), ('battery_dashboard', ()),
    ('battery_sim', ()), ('fake_base', ())])
def test_a_malformed_ros_args_is_one_line_and_exit_2(executable, args):
    code, output = run(executable, *(args + BAD))
    # rcl logs its own '[ERROR] [rcl]: Failed to parse global arguments' first, as for any ROS 2 node
    lines = [line for line in output.splitlines() if line.strip() and '[rcl]' not in line]
    assert code == 2, 'exit %r:\n%s' % (code, output)
    assert 'Traceback' not in output and len(lines) == 1, 'one line, no traceback:\n%s' % output
    # the command lines say it as "<executable>: bad --ros-args: ...", the nodes as their other start-up lines
    assert '-p frame_id:=' in lines[0] and lines[0].startswith((executable, '[FATAL]')), \
        'the line names the argument:\n%s' % output
