"""Every shipped preset starts at 0, 50 and 100 % on ROS 2 (issue 33, item 2): battery_sim publishes
battery_status with the level it was given (the gauge's start error clamped to 0-100 %) and ends cleanly.
On main lg_hg2_7s4p_aged died at 100 % ("gauge at 102.0 %"), the default start of the launch files."""
import os
import time

import pytest
import yaml
from sensor_msgs.msg import BatteryState

from ros2_probe import NodeProcess, Probe

PRESETS = os.path.join(os.path.dirname(os.path.abspath(__file__)), '..', '..', 'config', 'presets')
LEVELS = (0.0, 50.0, 100.0)


def preset_names():
    return sorted(name[:-len('.yaml')] for name in os.listdir(PRESETS) if name.endswith('.yaml'))


def initial_error(name):
    """The preset's gauge start error, points (0 without a coulomb counter)."""
    with open(os.path.join(PRESETS, name + '.yaml'), encoding='utf-8') as stream:
        values = yaml.safe_load(stream)
    gauge = values.get('gauge') or {}
    return gauge.get('initial_error', 0.0)


@pytest.fixture(scope='module')
def probe():
    probe = Probe('presets_probe')
    yield probe
    probe.close()


@pytest.mark.parametrize('name', preset_names())
def test_a_preset_starts_at_0_50_and_100_percent(probe, name):
    processes = {}
    try:
        for level in LEVELS:
            ns = '/p_%s_%d' % (name, level)
            processes[ns] = (level, NodeProcess('battery_sim', '-r', '__ns:=' + ns, '-p',
                                                'config:=' + os.path.join(PRESETS, name + '.yaml'),
                                                '-p', 'initial_percentage:=%g' % level, '-p', 'time_scale:=1.0'))
        since = time.monotonic()
        for ns, (level, process) in processes.items():
            msg, deadline = None, time.monotonic() + 60.0   # a node that died is not waited for
            while msg is None and time.monotonic() < deadline and process.process.poll() is None:
                msg = probe.wait_for(ns + '/battery_status', BatteryState, timeout_s=1.0, since=since)
            assert msg is not None, 'no battery_status from %s at %g %% within 60 s:\n%s' % (name, level,
                                                                                        process.output())
            expected = min(100.0, max(0.0, level + initial_error(name))) / 100.0
            assert abs(msg.percentage - expected) <= 0.005, (name, level, msg.percentage, expected)
    finally:
        codes = {ns: process.stop() for ns, (_, process) in processes.items()}
    for ns, (level, process) in processes.items():
        output = process.output()
        assert codes[ns] == 0 and 'Traceback' not in output, (name, level, codes[ns], output)
