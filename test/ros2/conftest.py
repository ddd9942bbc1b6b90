"""The ROS 2 tests run under tools/ros2.sh (the venv's python, DDS on 127.0.0.1 only). Each run gets
a ROS domain of its own, so two runs on one machine (ctest runs several test files at once) never see each
other: a domain is taken by holding a lock file for it for the run's life."""
import fcntl
import os
import shutil
import sys
import tempfile

import pytest
from sensor_msgs.msg import BatteryState

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
from ros2_probe import NodeProcess, Probe  # noqa: E402 (found in HERE)

DOMAINS = range(1, 101)
_held = []   # the lock file of this run's domain, open (and locked) until the process ends


def take_domain(start):
    """The first domain from ``start`` (wrapping) whose lock this process gets; it holds it."""
    for offset in range(len(DOMAINS)):
        domain = DOMAINS[(start + offset) % len(DOMAINS)]
        lock = open(os.path.join(tempfile.gettempdir(), 'battery_simulator_ros2_domain_%d.lock' % domain), 'a')
        try:
            fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            lock.close()
            continue
        _held.append(lock)
        return domain
    raise RuntimeError('every ROS domain 1-100 is taken by another test run on this machine')


def pytest_configure(config):
    assert os.environ.get('ROS_VERSION') == '2' and os.environ.get('FASTDDS_DEFAULT_PROFILES_FILE'), \
        'run the ROS 2 tests through tools/ros2.sh (it keeps DDS on this machine)'
    assert os.environ.get('ROS_AUTOMATIC_DISCOVERY_RANGE') == 'SYSTEM_DEFAULT'
    # before any node starts; the pid spreads concurrent runs, the lock makes them differ
    os.environ['ROS_DOMAIN_ID'] = str(take_domain(os.getpid() % len(DOMAINS)))
    # every temporary file this run makes (its nodes' logs, parameter files) in a directory of its own, removed
    # at its end (each node started left its log in /tmp: test_ros_args alone 5 files; the domain locks above
    # stay there, shared between runs)
    tempfile.tempdir = tempfile.mkdtemp(prefix='battery_simulator_ros2_test_')


def pytest_unconfigure(config):
    if tempfile.tempdir and os.path.basename(tempfile.tempdir).startswith('battery_simulator_ros2_test_'):
        shutil.rmtree(tempfile.tempdir, ignore_errors=True)
        tempfile.tempdir = None


@pytest.fixture(scope='module')
def probe():
    probe = Probe()
    yield probe
    probe.close()


@pytest.fixture(scope='module')
def sim(probe):
    """One battery_sim in /sim, fast (time x200, 20 Hz updates, battery_status at 5 Hz)."""
    process = NodeProcess('battery_sim', '-r', '__ns:=/sim', '-p', 'time_scale:=100.0', '-p', 'update_rate:=20.0',
                          '-p', 'rate:=5.0')
    assert probe.wait_for('/sim/battery_status', BatteryState, timeout_s=20.0) is not None, \
        'no battery_status from battery_sim within 20 s:\n' + process.output()
    yield process
    assert process.stop() == 0, 'battery_sim did not end cleanly on SIGINT:\n' + process.output()
    assert 'Traceback' not in process.output(), process.output()
