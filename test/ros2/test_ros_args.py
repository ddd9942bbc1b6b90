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


# -- issue 40 item 9: SIGINT while an executable still imports --------------------------------------------------

@pytest.mark.parametrize('executable, args', [('battery_sim', ()), ('battery_fleet', ()), ('battery_sim_client', ('1',))])
def test_sigint_while_importing_is_one_line_never_a_traceback(executable, args):
    """SIGINT 5-100 ms after start (Python and rclpy still importing; measured before: a KeyboardInterrupt
    traceback and exit 1 in 2 of 7 starts): at most one line, exit 130 or 0 (-2: the signal came before the
    interpreter ran at all, which a shell reports as 130)."""
    import signal
    import subprocess
    import time
    for delay_s in (0.005, 0.015, 0.025, 0.035, 0.045, 0.06, 0.08, 0.1):
        process = subprocess.Popen([executable, *args], stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        time.sleep(delay_s)
        process.send_signal(signal.SIGINT)
        output, _ = process.communicate(timeout=30)
        lines = [line for line in output.splitlines() if line.strip()]
        assert process.returncode in (0, 130, -signal.SIGINT) and 'Traceback' not in output and len(lines) <= 1, \
            'SIGINT %g s after start: exit %s:\n%s' % (delay_s, process.returncode, output)
