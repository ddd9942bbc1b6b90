#!/usr/bin/python3
"""rostest: the cut-off gate forwards TwistStamped as TwistStamped (and Twist as Twist), its stop at Empty is
of the type it forwards, and fake_base drives on either (test/ros1/twist_stamped.test)."""
import threading
import unittest

import rosgraph
import rospy
import rostest
from geometry_msgs.msg import Twist, TwistStamped
from nav_msgs.msg import Odometry

from battery_simulator.msg import BatterySimState
from rostest_helpers import Recorder, wait_for


def topic_type(topic):
    return dict(rosgraph.Master('/test_twist_stamped').getTopicTypes()).get(rospy.resolve_name(topic))


class Repeater(threading.Thread):
    """Publishes a message at 20 Hz until stopped."""

    def __init__(self, publisher, msg):
        super().__init__(daemon=True)
        self.publisher, self.msg, self.stop = publisher, msg, threading.Event()

    def run(self):
        while not self.stop.wait(0.05):
            if isinstance(self.msg, TwistStamped):
                self.msg.header.stamp = rospy.Time.now()
            self.publisher.publish(self.msg)


class TestTwistStamped(unittest.TestCase):

    @classmethod
    def setUpClass(cls):
        rospy.init_node('test_twist_stamped')

    def drive(self, ns, msg_type, msg):
        odom = Recorder(ns + '/odom', Odometry)
        state = rospy.Publisher(ns + '/battery_simulator/state', BatterySimState, queue_size=1, latch=True)
        repeater = Repeater(rospy.Publisher(ns + '/nav', msg_type, queue_size=1), msg)
        repeater.start()
        try:
            # the gate advertises the type it forwards (a typed subscriber that met the other type reconnects
            # when it changes; this one subscribes once the type is known)
            wait_for(lambda: topic_type(ns + '/cmd_vel') == msg_type._type, 20.0, 'the gate advertising %s in %s'
                     % (msg_type._type, ns))
            out = Recorder(ns + '/cmd_vel', msg_type)
            forwarded = out.wait_until(lambda m: True, 20.0, 'a %s forwarded on %s/cmd_vel' % (msg_type.__name__, ns))
            moved = odom.wait_until(lambda m: m.pose.pose.position.x > 0.1, 20.0, 'fake_base driving in ' + ns)
            self.assertGreater(moved.twist.twist.linear.x, 0.0)
            seen = out.count()
            state.publish(BatterySimState(charging_state='Empty', cut_off='test'))
            stop = out.wait_new(seen, lambda m: (m.twist if msg_type is TwistStamped else m).linear.x == 0.0,
                                10.0, 'a zero %s at Empty' % msg_type.__name__)
            return forwarded, stop
        finally:
            repeater.stop.set()

    def test_twist_stamped_is_forwarded_as_twist_stamped_and_drives_the_base(self):
        msg = TwistStamped()
        msg.header.frame_id, msg.twist.linear.x = 'base_link', 0.4
        forwarded, stop = self.drive('stamped', TwistStamped, msg)
        self.assertEqual(forwarded.header.frame_id, 'base_link')
        self.assertAlmostEqual(forwarded.twist.linear.x, 0.4)
        self.assertEqual(stop.header.frame_id, 'base_link', 'the stop is a TwistStamped in the same frame')

    def test_twist_is_forwarded_as_twist_and_drives_the_base(self):
        msg = Twist()
        msg.linear.x = 0.4
        forwarded, _ = self.drive('plain', Twist, msg)
        self.assertAlmostEqual(forwarded.linear.x, 0.4)


if __name__ == '__main__':
    rostest.rosrun('battery_simulator', 'twist_stamped', TestTwistStamped)
