"""battery_sim_client against battery_sim (ROS 2 twin of test/ros1/client.test): a charge goal to Full exits 0
with the result; a bad argument is a usage error (exit 2)."""
import subprocess

from ros2_probe import set_state


def test_client_charges_to_full(sim, probe):
    assert set_state(probe, '/sim', 99.5).success
    done = subprocess.run(['battery_sim_client', '1', '--ros-args', '-r', '__ns:=/sim'], capture_output=True,
                          text=True, timeout=60)
    assert done.returncode == 0, done.stdout + done.stderr
    assert 'Result: Full (succeeded)' in done.stdout, done.stdout
    usage = subprocess.run(['battery_sim_client', 'maybe'], capture_output=True, text=True, timeout=30)
    assert usage.returncode == 2 and 'usage' in usage.stderr
