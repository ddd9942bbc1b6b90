#!/usr/bin/python3
"""rostest: the battery_simulator action, the mode parameter and battery_status,
end to end against sim.launch (test/ros1/action_interface.test, time_scale 1000)."""
import math
import threading
import time
import unittest

import actionlib
import rospy
import rostest
from rospy.impl.paramserver import get_param_server_cache
from actionlib_msgs.msg import GoalStatus
from rosgraph_msgs.msg import Log
from sensor_msgs.msg import BatteryState

from battery_simulator.msg import BatterySimState, battery_simAction, battery_simGoal
from battery_simulator.srv import SetState
from rostest_helpers import Recorder, SetStateProxy, result_name, wait_for

MODE_PARAM = 'MyRobot/BatteryStatus'
GOAL_TIMEOUT_S = 60.0
NAN = float('nan')


class FeedbackLog:
    def __init__(self):
        self.lock = threading.Lock()
        self.values = []

    def __call__(self, feedback):
        with self.lock:
            self.values.append(feedback.battery_percentage)

    def snapshot(self):
        with self.lock:
            return list(self.values)


class TestActionInterface(unittest.TestCase):

    @classmethod
    def setUpClass(cls):
        rospy.init_node('test_action_interface')
        cls.client = actionlib.SimpleActionClient('battery_simulator', battery_simAction)
        assert cls.client.wait_for_server(rospy.Duration(30.0)), 'Could not connect to battery_simulator'
        cls.status = Recorder('battery_status')
        cls.log = Recorder('/rosout', Log)
        cls.state = Recorder('battery_simulator/state', BatterySimState)
        rospy.wait_for_service('battery_simulator/set_state', 30.0)
        cls.set_state = SetStateProxy('battery_simulator/set_state')
        wait_for(lambda: cls.status.count() > 0, 30.0, 'the first battery_status')

    def tearDown(self):
        # Cancel this test's goal only (a cancel-all could overtake the next goal).
        if self.client.simple_state != actionlib.SimpleGoalState.DONE:
            self.client.cancel_goal()
            self.client.wait_for_result(rospy.Duration(10.0))

    # -- helpers --------------------------------------------------------------

    def run_goal(self, charge):
        feedback = FeedbackLog()
        self.client.send_goal(battery_simGoal(charge_state=charge), feedback_cb=feedback)
        self.assertTrue(self.client.wait_for_result(rospy.Duration(GOAL_TIMEOUT_S)), 'goal did not end')
        return self.client.get_state(), self.client.get_result(), feedback.snapshot()

    def start_goal(self, charge):
        feedback = FeedbackLog()
        self.client.send_goal(battery_simGoal(charge_state=charge), feedback_cb=feedback)
        wait_for(lambda: len(feedback.snapshot()) >= 2, 10.0, 'feedback')
        return feedback

    def discharge_below(self, percentage):
        """Discharging, just below ``percentage`` (set_state puts it there: goals start near their ends)."""
        rospy.set_param(MODE_PARAM, 0)
        self.assertTrue(self.set_state(percentage - 0.5, NAN, NAN).success)
        self.status.wait_until(lambda m: m.current < 0 and m.percentage < percentage / 100.0, 30.0,
                               'discharging below %g %%' % percentage)

    # -- goals ----------------------------------------------------------------

    def test_charge_goal_streams_feedback_and_succeeds_full(self):
        self.discharge_below(80)
        updates = self.state.count()
        state, result, feedback = self.run_goal(True)
        updates = self.state.count() - updates
        self.assertEqual(state, GoalStatus.SUCCEEDED)
        self.assertEqual(result.battery_status, 'Full')
        self.assertEqual(rospy.get_param(MODE_PARAM), 1)
        self.assertGreater(len(feedback), 15)
        self.assertGreaterEqual(len(feedback), updates - 2, 'feedback at every model update')
        self.assertTrue(all(0.0 <= f <= 100.0 for f in feedback))
        self.assertEqual(feedback, sorted(feedback), 'charging never lowers the level')
        # from the start, 79.5 %: SimpleActionClient drops feedback that beats send_goal's return
        # (its gh is not set yet), and the next is an update (100 s of charge at time x1000) later
        self.assertLess(feedback[0], 81.0)
        self.assertGreater(feedback[-1], 97.0, 'feedback runs up to full')
        full = self.status.wait_until(lambda m: m.power_supply_status == BatteryState.POWER_SUPPLY_STATUS_FULL,
                                      10.0, 'FULL on battery_status')
        self.assertAlmostEqual(full.percentage, 1.0, places=5)
        self.assertGreater(full.current, 0.5, 'held full on the charger, which carries the base load (Part 7)')

    def test_discharge_goal_succeeds_empty_and_stops_at_cut_off(self):
        self.discharge_below(15)
        state, result, feedback = self.run_goal(False)
        self.assertEqual(state, GoalStatus.SUCCEEDED)
        self.assertEqual(result.battery_status, 'Empty')
        self.assertEqual(rospy.get_param(MODE_PARAM), 0)
        self.assertEqual(feedback, sorted(feedback, reverse=True), 'discharging never raises the level')
        self.assertGreaterEqual(min(feedback), 0.0)
        self.assertLess(feedback[-1], 5.0)
        empty = self.status.wait_until(lambda m: m.current == 0.0, 10.0, 'the load disconnected')
        self.assertEqual(empty.power_supply_status, BatteryState.POWER_SUPPLY_STATUS_NOT_CHARGING,
                         'EMPTY is reported as NOT_CHARGING (no current flows)')
        self.assertGreaterEqual(empty.percentage, 0.0)
        self.assertGreater(empty.voltage, 3 * 2.8 - 0.01)
        # a goal that starts where it would end succeeds at once
        state, result, _ = self.run_goal(False)
        self.assertEqual((state, result.battery_status), (GoalStatus.SUCCEEDED, 'Empty'))

    def test_charge_goal_when_full_succeeds_at_once(self):
        self.discharge_below(98)
        self.run_goal(True)
        state, result, feedback = self.run_goal(True)
        self.assertEqual((state, result.battery_status), (GoalStatus.SUCCEEDED, 'Full'))
        self.assertLessEqual(len(feedback), 2)

    def test_new_goal_preempts_the_active_one(self):
        self.discharge_below(90)
        first = actionlib.SimpleActionClient('battery_simulator', battery_simAction)
        self.assertTrue(first.wait_for_server(rospy.Duration(10.0)))
        first.send_goal(battery_simGoal(charge_state=True))
        wait_for(lambda: first.get_state() == GoalStatus.ACTIVE, 10.0, 'the first goal active')
        second = self.start_goal(False)
        self.assertTrue(first.wait_for_result(rospy.Duration(10.0)), 'first goal did not end')
        self.assertEqual(first.get_state(), GoalStatus.PREEMPTED)
        text = first.get_result().battery_status
        self.assertIn('Preempted', text)
        self.assertIn('new goal', text)
        self.assertRegex(text, r'\d+\.\d %')
        # the client learns ACTIVE from a goal status message, which may come after the feedback
        wait_for(lambda: self.client.get_state() == GoalStatus.ACTIVE, 2.0, 'the new goal running on')
        self.assertTrue(second.snapshot())

    def test_cancel_preempts_with_the_level(self):
        self.discharge_below(90)
        self.start_goal(True)
        self.client.cancel_goal()
        self.assertTrue(self.client.wait_for_result(rospy.Duration(10.0)))
        self.assertEqual(self.client.get_state(), GoalStatus.PREEMPTED)
        self.assertRegex(self.client.get_result().battery_status, r'Preempted at \d+\.\d % \(cancel')

    def test_parameter_changed_against_the_goal_aborts_it(self):
        self.discharge_below(90)
        self.start_goal(True)
        rospy.set_param(MODE_PARAM, 0)
        self.assertTrue(self.client.wait_for_result(rospy.Duration(10.0)))
        self.assertEqual(self.client.get_state(), GoalStatus.ABORTED)
        text = self.client.get_result().battery_status
        self.assertIn('Aborted', text)
        self.assertIn('MyRobot/BatteryStatus', text)
        self.status.wait_until(lambda m: m.current < 0, 5.0, 'discharging after the change')

    def test_parameter_changed_against_a_discharging_goal_aborts_it(self):
        self.discharge_below(90)
        self.start_goal(False)
        rospy.set_param(MODE_PARAM, 1)
        self.assertTrue(self.client.wait_for_result(rospy.Duration(10.0)))
        self.assertEqual(self.client.get_state(), GoalStatus.ABORTED)
        text = self.client.get_result().battery_status
        self.assertIn('Aborted', text)
        self.assertIn('charge', text)

    def test_feedback_comes_at_least_once_a_second(self):
        self.discharge_below(90)
        arrivals = []
        self.client.send_goal(battery_simGoal(charge_state=True),
                              feedback_cb=lambda feedback: arrivals.append(time.monotonic()))
        wait_for(lambda: len(arrivals) >= 8, 10.0, 'eight feedback messages')
        self.client.cancel_goal()
        gaps = [b - a for a, b in zip(arrivals, arrivals[1:8])]
        self.assertLess(max(gaps), 1.0, 'feedback gaps %s' % gaps)

    # -- the mode parameter ----------------------------------------------------

    def test_parameter_drives_the_mode_within_an_update(self):
        self.discharge_below(60)
        # The master pushes a set to its subscribers from its thread pool: on a busy machine the push can come
        # later than an update. This process subscribes too, and its own push is the reference measured in the
        # same run: the server follows within one update of the time the push reached this process.
        pushed = []
        mode_param = rospy.resolve_name(MODE_PARAM)
        get_param_server_cache().set_notifier(
            lambda key, value: pushed.append(value) if key.rstrip('/') == mode_param else None)
        rospy.get_param_cached(MODE_PARAM, None)
        for value, wanted in ((True, 'Charging'), (0, 'Discharging'), (1, 'Charging'), (False, 'Discharging')):
            pushes = len(pushed)
            rospy.set_param(MODE_PARAM, value)
            wait_for(lambda: len(pushed) > pushes, 10.0, 'the master\'s push of %s' % MODE_PARAM)
            # the update that reads the parameter, or the one after it if one was under way
            followed = self.state.next_after(self.state.count() + 1)
            self.assertEqual(followed.charging_state, wanted, '%r not followed within one update' % (value,))
        discharging = self.status.wait_until(lambda m: m.current < 0, 5.0, 'discharging')
        self.assertEqual(discharging.power_supply_status, BatteryState.POWER_SUPPLY_STATUS_DISCHARGING)

    def test_junk_parameter_values_are_logged_and_ignored(self):
        self.discharge_below(95)
        for junk in ('charge', 2, -1, 0.5, [1, 0]):
            logged = self.log.count()
            rospy.set_param(MODE_PARAM, junk)
            self.log.wait_new(logged, lambda m: m.level == Log.ERROR and 'BatteryStatus' in m.msg
                              and repr(junk) in m.msg, 10.0, 'an error naming %r' % (junk,))
            seen = self.status.count()
            after = self.status.next_after(seen + 1)
            self.assertLess(after.current, 0.0, 'still discharging (not holding) after %r' % (junk,))
            self.assertEqual(after.power_supply_status, BatteryState.POWER_SUPPLY_STATUS_DISCHARGING)
        rospy.set_param(MODE_PARAM, 1)
        self.status.wait_until(lambda m: m.current > 0, 5.0, 'charging once the value is valid again')

    def test_unset_parameter_holds_the_level_and_reports_not_charging(self):
        self.discharge_below(95)
        rospy.delete_param(MODE_PARAM)
        held = self.status.wait_until(
            lambda m: m.power_supply_status == BatteryState.POWER_SUPPLY_STATUS_NOT_CHARGING, 5.0, 'NOT_CHARGING')
        seen = self.status.count()
        later = self.status.next_after(seen + 2)
        self.assertEqual(later.percentage, held.percentage, 'the level holds')
        self.assertEqual(later.current, 0.0)
        rospy.set_param(MODE_PARAM, 0)

    # -- battery_status --------------------------------------------------------

    def test_battery_state_fields_follow_the_message_definition(self):
        rospy.set_param(MODE_PARAM, 0)
        msg = self.status.wait_until(lambda m: m.current < 0, 30.0, 'a discharging state')
        self.check_fields(msg)
        self.assertEqual(msg.power_supply_status, BatteryState.POWER_SUPPLY_STATUS_DISCHARGING)
        self.discharge_below(90)
        rospy.set_param(MODE_PARAM, 1)
        msg = self.status.wait_until(lambda m: m.current > 0, 10.0, 'a charging state')
        self.check_fields(msg)
        self.assertEqual(msg.power_supply_status, BatteryState.POWER_SUPPLY_STATUS_CHARGING)

    def check_fields(self, msg):
        self.assertGreater(msg.header.stamp.to_sec(), 0.0)
        self.assertEqual(msg.header.frame_id, 'battery', 'the default ~frame_id')
        self.assertTrue(7.0 < msg.voltage < 12.7, 'a 3S Li-ion pack voltage: %g' % msg.voltage)
        self.assertTrue(0.0 < msg.temperature < 60.0)
        self.assertTrue(0.0 <= msg.percentage <= 1.0)
        self.assertGreater(msg.capacity, 0.0)
        self.assertGreaterEqual(msg.design_capacity, msg.capacity)
        self.assertAlmostEqual(msg.charge, msg.percentage * msg.capacity, places=3)
        self.assertEqual(msg.power_supply_health, BatteryState.POWER_SUPPLY_HEALTH_GOOD)
        self.assertEqual(msg.power_supply_technology, BatteryState.POWER_SUPPLY_TECHNOLOGY_LION)
        self.assertTrue(msg.present)
        self.assertEqual(len(msg.cell_voltage), 3, 'one entry per series cell')
        self.assertEqual(len(msg.cell_temperature), 3)
        self.assertAlmostEqual(sum(msg.cell_voltage), msg.voltage, places=3)
        self.assertTrue(msg.location and msg.serial_number)
        for value in (msg.voltage, msg.current, msg.charge, msg.capacity, msg.temperature):
            self.assertFalse(math.isnan(value))

    def test_feedback_and_topic_describe_the_same_battery(self):
        self.discharge_below(60)
        seen = self.status.count()
        feedback = self.start_goal(True)
        wait_for(lambda: self.status.count() >= seen + 6, 10.0, 'battery_status during the goal')
        # read before the cancel: a battery_status after it (the charge goes on) has no feedback; and the feedback
        # of the last ones may still be on its way (another topic, another connection), so it is waited for
        topic = [m.percentage for m in self.status.since(seen + 1) if m.current > 0]
        self.assertGreaterEqual(len(topic), 3)

        def unmatched():
            values = feedback.snapshot()
            return ['%.6f' % (100.0 * p) for p in topic
                    if not any(abs(f - 100.0 * p) <= 1e-4 * max(1.0, f) for f in values)]
        wait_for(lambda: not unmatched(), 10.0, 'a feedback value for each battery_status of the goal')
        self.client.cancel_goal()


if __name__ == '__main__':
    rostest.rosrun('battery_simulator', result_name('action_interface'), TestActionInterface)
