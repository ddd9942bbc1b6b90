"""The nodes' guards against bad input that need no master: the noisy readings'
bounds and the worker guard that ends a node whose worker died."""
from unittest import mock

import pytest

from battery_simulator.core import battery_record

startup = pytest.importorskip('battery_simulator.ros1.startup', reason='needs the devel space (tools/run_tests.sh)')
BatteryState = pytest.importorskip('sensor_msgs.msg').BatteryState


@pytest.mark.parametrize('noise_v', [-1e6, -12.6, -6.0, 0.0, 1e6])
def test_a_noisy_voltage_is_never_zero_negative_or_wild(noise_v):
    reading = battery_record.noisy_voltage(12.6, noise_v)
    assert 6.3 <= reading <= 25.2


@pytest.mark.parametrize('status, current_a, noise_a, expected', [
    (BatteryState.POWER_SUPPLY_STATUS_DISCHARGING, -1.5, +5.0, 0.0),
    (BatteryState.POWER_SUPPLY_STATUS_DISCHARGING, -1.5, -1.0, -2.5),
    (BatteryState.POWER_SUPPLY_STATUS_CHARGING, 1.5, -5.0, 0.0),
    (BatteryState.POWER_SUPPLY_STATUS_CHARGING, 1.5, 0.5, 2.0),
    (BatteryState.POWER_SUPPLY_STATUS_NOT_CHARGING, 0.0, -0.25, -0.25),   # a sensor's offset around zero
])
def test_a_noisy_current_never_contradicts_the_status(status, current_a, noise_a, expected):
    assert battery_record.noisy_current(current_a, noise_a, status) == expected


def test_an_exception_that_ends_a_worker_ends_the_node_with_one_fatal_line():
    with mock.patch.object(startup.rospy, 'logfatal') as logfatal, \
            mock.patch.object(startup.os, '_exit', side_effect=SystemExit(1)) as exit_now, \
            mock.patch.object(startup.time, 'sleep'):
        with pytest.raises(SystemExit):
            with startup.ending_the_node_on_error('the battery model worker'):
                1.0 / 0.0
    exit_now.assert_called_once_with(1)
    logfatal.assert_called_once()
    line = logfatal.call_args[0][0] % logfatal.call_args[0][1:]
    assert line.startswith('the battery model worker failed (ZeroDivisionError: float division by zero)')
    assert 'respawn' in line


def test_a_worker_that_ends_normally_leaves_the_node_alone():
    with mock.patch.object(startup.os, '_exit') as exit_now:
        with startup.ending_the_node_on_error('a worker'):
            pass
    exit_now.assert_not_called()


def test_only_roslaunch_is_asked_to_stop_the_launch(tmp_path):
    assert not startup._is_roslaunch(1 << 30)   # no such process
    with mock.patch('builtins.open', mock.mock_open(read_data=b'/usr/bin/python3\0/usr/bin/roslaunch\0pkg\0')):
        assert startup._is_roslaunch(1234)
    with mock.patch('builtins.open', mock.mock_open(read_data=b'/usr/bin/python3\0/usr/bin/rostest\0x.test\0')):
        assert not startup._is_roslaunch(1234)
    with mock.patch('builtins.open', mock.mock_open(read_data=b'bash\0-c\0roslaunch\0')):
        assert not startup._is_roslaunch(1234)
