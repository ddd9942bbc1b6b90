#!/usr/bin/python3
"""rostest: battery_simulator/predict against what the battery then does
(test/ros1/prediction.test, robot1, time x100, 50 updates a second).

Each agreement test asks for a prediction, then applies the same plan for real
(set_load for power, cmd_vel for motion, set_charging for the charge), paced
by the clock (wall time x time_scale is the battery's time), and compares:
the end level within 1 percentage point, the cut-off and the charge time
within 2 %. Bad requests get success false and change nothing."""
import bisect
import math
import threading
import time
import unittest

import rospy
import rostest
from geometry_msgs.msg import Twist
from std_srvs.srv import SetBool

from battery_simulator.core.config_files import default_config_path, load_yaml
from battery_simulator.msg import BatterySimState
from battery_simulator.srv import Predict, PredictRequest, SetLoad, SetState
from rostest_helpers import Recorder, SetStateProxy, result_name, wait_for

MODE_PARAM = 'MyRobot/BatteryStatus'
NAN = float('nan')
PLAN_LOAD = 'test_plan'
PAYLOAD = 'test_lidar'
PAYLOAD_W = 5.0


class MotionCommands:
    """cmd_vel at 50 Hz while a motion is set (a robot's controller); set(0, 0) sends one stop.

    Every publish happens under the lock: a repeat read before a stop and published after it would
    drive the battery on for cmd_vel_timeout (200 s of its time at x400; a CI run with CPU hogs ended
    2.6 points low)."""

    def __init__(self, publisher):
        self._publisher = publisher
        self._twist = None
        self._lock = threading.Lock()
        threading.Thread(target=self._run, daemon=True).start()

    def set(self, speed_mps, turn_radps):
        twist = Twist()
        twist.linear.x, twist.angular.z = speed_mps, turn_radps
        with self._lock:
            self._publisher.publish(twist)
            self._twist = twist if speed_mps or turn_radps else None

    def _run(self):
        while not rospy.is_shutdown():
            with self._lock:
                if self._twist is not None:
                    self._publisher.publish(self._twist)
            time.sleep(0.02)


class TestPrediction(unittest.TestCase):

    @classmethod
    def setUpClass(cls):
        rospy.init_node('test_prediction')
        cls.time_scale = rospy.get_param('~time_scale')
        cls.pack = load_yaml(default_config_path())   # the pack prediction.launch runs (its motion's power)
        cls.state = Recorder('battery_simulator/state', BatterySimState)
        for service in ('predict', 'set_state', 'set_load', 'set_charging'):
            rospy.wait_for_service('battery_simulator/' + service, 30.0)
        cls.predict = rospy.ServiceProxy('battery_simulator/predict', Predict, persistent=True)
        cls.set_state = SetStateProxy('battery_simulator/set_state')
        cls.set_load = rospy.ServiceProxy('battery_simulator/set_load', SetLoad)
        cls.set_charging = rospy.ServiceProxy('battery_simulator/set_charging', SetBool)
        cmd_vel = rospy.Publisher('cmd_vel', Twist, queue_size=10)
        wait_for(lambda: cmd_vel.get_num_connections() > 0, 30.0, 'the server on cmd_vel')
        cls.motion = MotionCommands(cmd_vel)
        wait_for(lambda: cls.state.count() > 0, 30.0, 'battery_simulator/state')

    def setUp(self):
        self.motion.set(0.0, 0.0)
        for name in (PLAN_LOAD, PAYLOAD):
            self.assertTrue(self.set_load(name, 0.0).success)
        self.set_charging(False)
        rospy.set_param(MODE_PARAM, 0)

    def start_at(self, percentage):
        """Discharging from ``percentage`` at 25 degC (the RC pair settled)."""
        self.state.wait_until(lambda m: m.charging_state == 'Discharging', 5.0, "setUp's discharging")
        sent = self.state.count()
        self.assertTrue(self.set_state(percentage, 25.0, NAN).success)
        # an update after the service's, discharging from it: at x400 a point goes in 0.2 s, so the update the
        # test receives on a busy machine may already be a few points down (none is above the level set)
        self.state.wait_new(sent, lambda m: m.charging_state == 'Discharging'
                            and percentage / 100.0 - 0.05 < m.battery.percentage <= percentage / 100.0 + 1e-6, 5.0,
                            'discharging from %g %%' % percentage)

    def ask(self, **fields):
        response = self.predict(PredictRequest(**dict(dict(charge_to_percentage=NAN), **fields)))
        self.assertTrue(response.success, response.message)
        return response

    def pace_until(self, plan_s, start):
        """Wait until ``plan_s`` of the battery's time have passed since ``start`` (wall stamp, s)."""
        until = start + plan_s / self.time_scale
        deadline = time.monotonic() + plan_s / self.time_scale + 10.0
        while rospy.get_time() < until:
            self.assertLess(time.monotonic(), deadline, 'the clock stands still')
            time.sleep(0.001)

    def percentage_at(self, stamp_s):
        """The level at ``stamp_s`` (wall), interpolated between the server's updates around it."""
        wait_for(lambda: self.state.latest().battery.header.stamp.to_sec() > stamp_s, 5.0, 'an update after it')
        states = [(m.battery.header.stamp.to_sec(), 100.0 * m.battery.percentage) for m in self.state.since(0)]
        k = bisect.bisect_left([t for t, _ in states], stamp_s)
        (t0, p0), (t1, p1) = states[k - 1], states[k]
        return p0 + (p1 - p0) * (stamp_s - t0) / (t1 - t0)

    def moment_of(self, predicate, since, timeout_s, what):
        """(earliest, latest): the battery's times (s since ``since``, a wall stamp) between which ``predicate``
        first held: the update before the one that saw it, and that one (the model finds the moment within its
        step; on a busy machine a step is tenths of a second late, at x400 a minute of battery)."""
        index = self.state.count()
        found = self.state.wait_new(index, predicate, timeout_s, what)
        states = self.state.since(0)
        k = next(i for i, m in enumerate(states) if m is found)
        return tuple((m.battery.header.stamp.to_sec() - since) * self.time_scale for m in (states[k - 1], found))

    def assert_within_2_percent(self, predicted_s, moment, what):
        """The predicted time within 2 % of the real moment, which lies in ``moment`` (earliest, latest)."""
        earliest, latest = moment
        rospy.loginfo('%s: predicted %.0f s, real %.0f-%.0f s', what, predicted_s, earliest, latest)
        allowed = 0.02 * predicted_s
        self.assertTrue(earliest - allowed <= predicted_s <= latest + allowed,
                        '%s: predicted %.0f s, real %.0f-%.0f s (within 2 %%: %.0f s)'
                        % (what, predicted_s, earliest, latest, allowed))

    # -- agreement ------------------------------------------------------------------

    def test_a_plan_of_power_and_motion_with_a_payload_ends_where_predicted(self):
        self.start_at(80.0)
        self.assertTrue(self.set_load(PAYLOAD, PAYLOAD_W).success)
        plan = [(600.0, 10.0, 0.0, 0.0), (600.0, 0.0, 0.2, 1.0), (600.0, 0.0, 0.0, 0.0)]
        # asked while the battery holds its level: the prediction starts from the level the plan starts from. Asked
        # while it discharged, it started where the service took the model, a call later than the test's start (at
        # x400 and 2 A, 0.008 points a millisecond: 2-7 ms quiet, 20 ms beside two CPU hogs)
        rospy.delete_param(MODE_PARAM)
        self.state.wait_until(lambda m: m.charging_state == 'Not Charging', 5.0, 'holding')
        predicted = self.ask(duration_s=[p[0] for p in plan], power_w=[p[1] for p in plan],
                             speed_mps=[p[2] for p in plan], turn_radps=[p[3] for p in plan])
        start = self.discharge_from_hold(plan[0][1])
        elapsed_s = plan[0][0]
        self.pace_until(elapsed_s, start)
        for duration_s, power_w, speed_mps, turn_radps in plan[1:]:
            if speed_mps or turn_radps:   # a service call takes a while on a busy machine: motion starts after it
                self.assertTrue(self.set_load(PLAN_LOAD, power_w).success)
                self.motion.set(speed_mps, turn_radps)
            else:                         # and stops before it
                self.motion.set(speed_mps, turn_radps)
                self.assertTrue(self.set_load(PLAN_LOAD, power_w).success)
            elapsed_s += duration_s
            self.pace_until(elapsed_s, start)
        self.motion.set(0.0, 0.0)
        real = self.percentage_at(start + elapsed_s / self.time_scale)
        late = self.drain_of_late_changes(start, plan)
        rospy.loginfo('plan: predicted %.2f %%, real %.2f %% (error %.2f pp; %.2f pp of it the test\'s own late '
                      'load changes); %s', predicted.end_percentage, real, real - predicted.end_percentage, -late,
                      predicted.message)
        self.assertTrue(predicted.feasible and math.isnan(predicted.cut_off_at_s), predicted.message)
        self.assertLess(predicted.end_percentage, 80.0 - 30.0, 'the plan takes a good part of the pack')
        self.assertLess(abs(late), 3.0, 'the plan\'s load changes came far from their moments')
        self.assertAlmostEqual(real, predicted.end_percentage - late, delta=1.0)

    def discharge_from_hold(self, power_w):
        """Start discharging a held battery with the plan load ``power_w`` (set while it holds: in force from the
        start); the start, a wall stamp: the last update held, as the server follows the mode before it steps
        (the step from that update to the first discharging one discharges)."""
        self.assertTrue(self.set_load(PLAN_LOAD, power_w).success)
        sent = self.state.count()
        rospy.set_param(MODE_PARAM, 0)
        first = self.state.wait_new(sent, lambda m: m.charging_state == 'Discharging', 5.0, 'discharging')
        states = self.state.since(0)
        held = states[next(k for k, m in enumerate(states) if m is first) - 1]
        self.assertEqual(held.charging_state, 'Not Charging', 'the update before the discharge')
        return held.battery.header.stamp.to_sec()

    def drain_of_late_changes(self, start, plan):
        """Points of charge the battery drew beyond the plan because this test changed the load late (a busy
        machine: at x400 a point goes in 0.2 s): the server's recorded load_power_w against each phase's own
        (its plan power, the payload and its motion's power in the pack the server runs), over the plan's
        moments, at the recorded voltage and the gauge's capacity. The phase's power is the plan's, not the
        recorded one's median: a CI run's set_load call took the motion phase's middle half (its motion
        command waited for the call), so the median was the payload's and the missing motion went uncounted
        (real 37.0 % against 29.3 %)."""
        durations_s = [duration_s for duration_s, _, _, _ in plan]
        end = start + sum(durations_s) / self.time_scale
        states = [m for m in self.state.since(0) if start <= m.battery.header.stamp.to_sec() <= end]
        bounds = [start + sum(durations_s[:k]) / self.time_scale for k in range(len(durations_s) + 1)]
        planned = [power_w + PAYLOAD_W + self.pack.motion_power_w(speed_mps, turn_radps)
                   for _, power_w, speed_mps, turn_radps in plan]
        extra_ah = 0.0
        for state, following in zip(states, states[1:]):
            t = state.battery.header.stamp.to_sec()
            phase = max(k for k in range(len(planned)) if bounds[k] <= t)
            span_s = (following.battery.header.stamp.to_sec() - t) * self.time_scale
            extra_ah += (state.load_power_w - planned[phase]) / state.battery.voltage * span_s / 3600.0
        return 100.0 * extra_ah / states[-1].gauge_full_capacity_ah

    def test_the_cut_off_comes_when_predicted(self):
        self.start_at(40.0)
        start = rospy.get_time()
        predicted = self.ask(duration_s=[3000.0], power_w=[20.0])
        self.assertTrue(self.set_load(PLAN_LOAD, 20.0).success)
        self.assertFalse(predicted.feasible, predicted.message)
        real = self.moment_of(lambda m: m.charging_state == 'Empty', start,
                              predicted.cut_off_at_s / self.time_scale + 10.0, 'the cut-off')
        self.assert_within_2_percent(predicted.cut_off_at_s, real, 'cut-off')

    def test_the_charge_takes_the_predicted_time(self):
        self.start_at(60.0)
        rospy.delete_param(MODE_PARAM)   # hold: the level stands still from the plans' answers to the charge
        self.state.wait_until(lambda m: m.charging_state == 'Not Charging', 5.0, 'holding')
        to_90 = self.ask(charge_to_percentage=90.0)
        to_full = self.ask(charge_to_percentage=100.0)
        sent = self.state.count()
        self.assertTrue(self.set_charging(True).success)
        # the charge starts between the last update held and the first charging (the server's stamps: at x400 the
        # test's own clock, a busy machine's tenths of a second late, would be a minute of battery)
        self.state.wait_new(sent, lambda m: m.charging_state == 'Charging', 5.0, 'the charge started')
        states = self.state.since(sent - 1)
        first = next(k for k, m in enumerate(states) if m.charging_state == 'Charging')
        start = 0.5 * (states[first - 1].battery.header.stamp.to_sec() + states[first].battery.header.stamp.to_sec())
        real_90 = self.moment_of(lambda m: m.battery.percentage >= 0.9, start,
                                 to_90.charge_time_s / self.time_scale + 10.0, '90 %')
        real_full = self.moment_of(lambda m: m.charging_state == 'Full', start,
                                   to_full.charge_time_s / self.time_scale + 10.0, 'Full')
        self.assert_within_2_percent(to_90.charge_time_s, real_90, 'charge to 90 %')
        self.assert_within_2_percent(to_full.charge_time_s, real_full, 'charge to Full')
        self.assertGreater(to_full.charge_time_s, to_90.charge_time_s + 600.0, 'the CV taper')

    def test_charge_to_percentage_left_out_means_no_charge(self):
        """A message's charge_to_percentage defaults to 0: no charge, as NaN (it answered "charged in 0 s")."""
        self.start_at(70.0)
        response = self.predict(PredictRequest(duration_s=[600.0], power_w=[5.0]))
        self.assertTrue(response.success, response.message)
        self.assertTrue(math.isnan(response.charge_time_s), response.charge_time_s)
        self.assertNotIn('charged', response.message)
        self.assertGreater(self.ask(duration_s=[600.0], charge_to_percentage=90.0).charge_time_s, 60.0)

    # -- bad requests ----------------------------------------------------------------

    def test_bad_requests_are_refused_naming_the_field_and_nothing_changes(self):
        self.start_at(70.0)
        rospy.delete_param(MODE_PARAM)   # hold: the level stands still, so any change would show
        held = self.state.wait_until(lambda m: m.charging_state == 'Not Charging', 5.0, 'holding')
        for fields, field in ((dict(duration_s=[60.0, 60.0], power_w=[1.0]), 'power_w'),
                              (dict(duration_s=[-1.0]), 'duration_s[0]'),
                              (dict(duration_s=[10.0, NAN]), 'duration_s[1]'),
                              (dict(duration_s=[8 * 86400.0]), 'duration_s'),
                              (dict(duration_s=[60.0], power_w=[1e6]), 'power_w[0]'),
                              (dict(duration_s=[60.0], current_a=[100.0]), 'current_a[0]'),
                              (dict(duration_s=[60.0], speed_mps=[1e9]), 'speed_mps[0]'),
                              (dict(charge_to_percentage=150.0), 'charge_to_percentage')):
            response = self.predict(PredictRequest(**dict(dict(charge_to_percentage=NAN), **fields)))
            self.assertFalse(response.success, '%r accepted' % fields)
            self.assertIn(field, response.message)
        # more segments than the limit: refused naming it, before the plan is unpacked (1 s each: 28 h, < 7 days)
        response = self.predict(PredictRequest(duration_s=[1.0] * 100001, charge_to_percentage=NAN))
        self.assertFalse(response.success, '100001 segments accepted')
        self.assertEqual(response.message, 'duration_s has 100001 entries, which is invalid: a plan has at most '
                                           '100000 segments (a day at one-second resolution)')
        heavy = self.ask(duration_s=[600.0, 3000.0], power_w=[50.0, 20.0], speed_mps=[0.2, 0.0],
                         charge_to_percentage=100.0)
        self.assertFalse(heavy.feasible)
        self.assertGreater(heavy.charge_time_s, 0.0)
        after = self.state.next_after(self.state.count() + 5)
        self.assertEqual(after.battery.percentage, held.battery.percentage, 'the level moved')
        self.assertEqual(after.charging_state, 'Not Charging')
        self.assertEqual(after.load_power_w, 0.0)
        self.assertFalse(rospy.has_param(MODE_PARAM), 'the mode parameter was touched')


if __name__ == '__main__':
    rostest.rosrun('battery_simulator', result_name('prediction'), TestPrediction)
