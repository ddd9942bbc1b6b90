"""The ROS 2 tests run under tools/ros2.sh (the venv's python, DDS on 127.0.0.1 only). Each run gets
a ROS domain of its own, so two runs on one machine do not see each other."""
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)


def pytest_configure(config):
    assert os.environ.get('ROS_VERSION') == '2' and os.environ.get('FASTDDS_DEFAULT_PROFILES_FILE'), \
        'run the ROS 2 tests through tools/ros2.sh (it keeps DDS on this machine)'
    assert os.environ.get('ROS_AUTOMATIC_DISCOVERY_RANGE') == 'SYSTEM_DEFAULT'
    # a domain of this run's own (1..100; the pid spreads concurrent runs), before any node starts
    os.environ['ROS_DOMAIN_ID'] = str(1 + os.getpid() % 100)
