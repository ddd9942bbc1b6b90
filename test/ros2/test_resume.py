"""A SIGKILLed battery_sim resumes from its state file within 1 % of its level, its state of health kept
(ROS 2 twin of test/ros1/resume.test)."""
import json
import signal
import time

from sensor_msgs.msg import BatteryState

from ros2_probe import NodeProcess, set_state


def test_resume_after_sigkill(probe, tmp_path):
    state_file = str(tmp_path / 'battery.json')
    args = ('-r', '__ns:=/resume', '-p', 'state_file:=' + state_file, '-p', 'time_scale:=1.0')
    process = NodeProcess('battery_sim', *args)
    try:
        assert probe.wait_for('/resume/battery_status', BatteryState, timeout_s=20.0) is not None, process.output()
        assert set_state(probe, '/resume', 42.0, state_of_health=0.9).success
        deadline = time.monotonic() + 10.0
        while time.monotonic() < deadline:
            try:
                with open(state_file, encoding='utf-8') as stream:
                    if abs(json.load(stream)['state_of_charge'] - 0.42) < 0.005:
                        break
            except (OSError, ValueError):
                pass
            time.sleep(0.05)
        else:
            raise AssertionError('the state file never held 42 %')
    finally:
        process.stop(signal.SIGKILL)
    again = NodeProcess('battery_sim', *args)
    try:
        msg = probe.wait_for('/resume/battery_status', BatteryState, timeout_s=20.0, since=time.monotonic())
        assert msg is not None, again.output()
        assert abs(msg.percentage - 0.42) < 0.01, 'resumed within 1 %% of 42 %% (%g)' % msg.percentage
        assert abs(msg.capacity / msg.design_capacity - 0.9) < 0.01, 'state of health kept'
        assert 'resumed from' in again.output()
    finally:
        again.stop()
