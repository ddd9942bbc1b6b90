"""A ROS 1 fleet host lets rospy look for broken connections on every topic at most every few seconds (issue 42):
rospy does it twice a second and after every connection request, which at 250 robots (3,000 topics) was a fifth
of a host's CPU (py-spy) and slowed its start while a thousand subscribers connected."""
import pytest

registration = pytest.importorskip('rospy.impl.registration')
from battery_simulator.ros1 import fleet_host  # noqa: E402


class CountingTopics:
    def __init__(self):
        self.checks = 0

    def check_all(self):
        self.checks += 1


@pytest.fixture
def topics():
    old = registration.get_topic_manager()
    manager = CountingTopics()
    registration.set_topic_manager(manager)
    yield manager
    registration.set_topic_manager(old)


def test_rospys_connection_checks_run_at_most_once_a_period(topics, monkeypatch):
    now = [1000.0]
    monkeypatch.setattr(fleet_host.time, 'monotonic', lambda: now[0])
    fleet_host.throttle_connection_checks(period_s=5.0)
    for _ in range(50):    # what rospy's registration thread does over 5 s, or during a burst of connections
        registration.get_topic_manager().check_all()
        now[0] += 0.1
    assert topics.checks == 1
    now[0] += 0.1
    registration.get_topic_manager().check_all()
    assert topics.checks == 2   # and still checks, once a period
