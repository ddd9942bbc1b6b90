"""A SIGKILLed battery_sim resumes from its state file within 1 % of its level, its state of health kept
(ROS 2 twin of test/ros1/resume.test)."""
import json
import signal
import time

from sensor_msgs.msg import BatteryState

import pytest

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


def test_a_restart_resumes_the_learning_gauges_learned_capacity(probe, tmp_path):
    """Issue 43: the state file carries what the gauge learned (a real gauge's flash). A state saved with a
    learned capacity 20 % below the configured belief: battery_status' capacity (the gauge's full charge
    capacity) is the learned one after the start, and the file written at the stop still holds it."""
    from battery_simulator.core.battery_states import Mode
    from battery_simulator.core.config_files import from_mapping
    from battery_simulator.core.pack import make_model
    config = tmp_path / 'learning.yaml'
    config.write_text('preset: lg_hg2_3s1p\ngauge: {model: learning}\n', encoding='utf-8')
    model = make_model(from_mapping({'preset': 'lg_hg2_3s1p', 'gauge': {'model': 'learning'}}), 0.6, Mode.IDLE)
    configured_ah = model.gauge_reading()[2]
    model.gauge.capacity_as *= 0.8
    model.gauge.learned = True
    model.step(0.0)
    state_file = tmp_path / 'battery.json'
    state_file.write_text(json.dumps(model.export_state()), encoding='utf-8')
    process = NodeProcess('battery_sim', '-r', '__ns:=/learned', '-p', 'config:=' + str(config),
                          '-p', 'state_file:=' + str(state_file), '-p', 'time_scale:=1.0')
    try:
        msg = probe.wait_for('/learned/battery_status', BatteryState, timeout_s=20.0)
        assert msg is not None, process.output()
        # (the full charge capacity at the start's load: a few % below the rest's; the fresh belief: 25 % above)
        assert msg.capacity == pytest.approx(0.8 * configured_ah, rel=0.05), (msg.capacity, configured_ah)
    finally:
        assert process.stop() == 0, process.output()
    saved = json.loads(state_file.read_text(encoding='utf-8'))
    assert saved['gauge_learned'] is True
    assert saved['gauge_capacity_ah'] == pytest.approx(model.gauge.capacity_ah, rel=1e-9)
