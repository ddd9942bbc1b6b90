#!/usr/bin/python3
"""rostest: what robots already run reads the battery unchanged (Part 7) - Nav2 Kilted's TwistStamped cmd_vel,
opennav_docking's battery_state under the robot's namespace (test/ros1/consumers.test, in /robot1)."""
import threading
import unittest

import rospy
import rostest
from geometry_msgs.msg import TwistStamped
from sensor_msgs.msg import BatteryState
from std_msgs.msg import Bool

from battery_simulator.msg import BatterySimState
from rostest_helpers import Recorder, SetStateProxy, wait_for

DRIVE_W_PER_MPS = 50.0      # the default preset's drive power
NAN = float('nan')


class TestConsumers(unittest.TestCase):

    @classmethod
    def setUpClass(cls):
        rospy.init_node('test_consumers')
        cls.state = Recorder('battery_simulator/state', BatterySimState)
        cls.status = Recorder('battery_status')
        wait_for(lambda: cls.state.count() > 0, 30.0, 'the server state')

    def test_a_twist_stamped_cmd_vel_drains_as_a_twist_does(self):
        cmd_vel = rospy.Publisher('cmd_vel', TwistStamped, queue_size=1)
        stop = threading.Event()

        def drive():
            msg = TwistStamped()
            msg.twist.linear.x = 0.5
            while not stop.wait(0.05):
                msg.header.stamp = rospy.Time.now()
                cmd_vel.publish(msg)
        threading.Thread(target=drive, daemon=True).start()
        try:
            # an update's load is its average over the update: the first one with the command is partial
            self.state.wait_until(lambda m: abs(m.load_power_w - DRIVE_W_PER_MPS * 0.5) < 1e-6, 10.0,
                                  'the drive power of 0.5 m/s (%g W) from a TwistStamped' % (DRIVE_W_PER_MPS * 0.5))
        finally:
            stop.set()
        self.state.wait_until(lambda m: m.load_power_w == 0.0, 5.0, 'a stale TwistStamped counts as standing')

    def test_battery_state_is_published_beside_battery_status_in_the_namespace(self):
        self.assertEqual(rospy.get_namespace(), '/robot1/')
        twin = rospy.wait_for_message('/robot1/battery_state', BatteryState, timeout=10.0)
        status = rospy.wait_for_message('/robot1/battery_status', BatteryState, timeout=10.0)
        self.assertAlmostEqual(twin.percentage, status.percentage, delta=0.01,
                               msg='battery_state and battery_status describe one battery')
        self.assertEqual(twin.serial_number, status.serial_number)

    def test_a_full_pack_on_the_dock_shows_the_chargers_current_and_leaving_drops_it(self):
        """opennav_docking's SimpleChargingDock: charging when current > 0.5 A, within 5 s of contact."""
        contact = rospy.Publisher('charger_contact', Bool, queue_size=1, latch=True)
        set_state = SetStateProxy('battery_simulator/set_state')
        try:
            self.assertTrue(set_state(100.0, NAN, NAN).success)
            seen = self.status.count()
            contact.publish(Bool(data=True))
            self.status.wait_new(seen, lambda m: m.current > 0.5, 5.0,
                                 'a full pack on the dock showing more than 0.5 A (the charger holds it full)')
            seen = self.status.count()
            contact.publish(Bool(data=False))
            self.status.wait_new(seen, lambda m: m.current < 0.5, 5.0, 'less than 0.5 A within 5 s of leaving')
        finally:
            contact.publish(Bool(data=False))

    def test_a_driver_that_inverts_the_sign_and_scales_the_percentage_is_emulated(self):
        gazebo = rospy.wait_for_message('/robot2/battery_status', BatteryState, timeout=10.0)
        truth = rospy.wait_for_message('/robot2/battery_simulator/state', BatterySimState, timeout=10.0)
        self.assertGreater(gazebo.percentage, 1.0, 'percentage on 0-100 as configured')
        self.assertAlmostEqual(gazebo.percentage / 100.0, truth.battery.percentage, delta=0.01)
        self.assertEqual(gazebo.power_supply_status, BatteryState.POWER_SUPPLY_STATUS_DISCHARGING)
        self.assertGreater(gazebo.current, 0.0, 'discharging shown positive, as an inverting driver does')


if __name__ == '__main__':
    rostest.rosrun('battery_simulator', 'consumers', TestConsumers)
