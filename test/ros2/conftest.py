"""The ROS 2 tests run under tools/ros2.sh (the venv's python, DDS on 127.0.0.1 only). Each run gets
a ROS domain of its own, so two runs on one machine (ctest runs several test files at once) never see each
other: a domain is taken by holding a lock file for it for the run's life."""
import fcntl
import os
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
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
