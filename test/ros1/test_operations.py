#!/usr/bin/python3
"""rostest: diagnostics (and their aggregation under Power System), the test
controls set_state / reset / inject_fault, and dynamic_reconfigure
(test/ros1/operations.test, time_scale 10, update_rate 100, rate 50)."""
import math
import statistics
import unittest

import actionlib
import rospy
import rostest
from actionlib_msgs.msg import GoalStatus
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from dynamic_reconfigure.client import Client as ReconfigureClient
from sensor_msgs.msg import BatteryState
from std_srvs.srv import Trigger

from battery_simulator.msg import BatterySimState, battery_simAction, battery_simGoal
from battery_simulator.srv import InjectFault, SetState
from rostest_helpers import Recorder, SetStateProxy, result_name, wait_for

MODE_PARAM = 'MyRobot/BatteryStatus'
NAN = float('nan')
KEYS = ['Voltage (V)', 'Current (A)', 'Charge (Ah)', 'Capacity (Ah)', 'Design Capacity (Ah)', 'Percentage (%)',
        'Temperature (C)', 'Charging State', 'Health', 'Cycle Count', 'State of Health (%)', 'Time Remaining (min)',
        'Cell Voltage Min (V)', 'Cell Voltage Max (V)', 'Cell Imbalance (mV)',   # Part 5's three
        'Gauge Corrections', 'Gauge Full Capacity (Ah)', 'Gauge Learned']        # Part 9's three
DEFAULTS = {'load_current_a': 1.5, 'time_scale': 10.0, 'load_power_w': 0.0, 'charge_current_a': 1.5,
            'ambient_temperature_c': 25.0, 'drive_power_w_per_mps': 50.0, 'turn_power_w_per_radps': 4.0}
SIGMA_V, SIGMA_A = 0.02, 0.05   # the default preset's voltage_noise_v, current_noise_a


def battery_status_of(array):
    """This battery's status: "<battery_state_pub's resolved name>: Battery" (a fleet host sends every robot's)."""
    name = rospy.resolve_name('battery_state_pub').lstrip('/') + ': Battery'
    found = [s for s in array.status if s.name == name]
    return found[0] if found else None


class TestOperations(unittest.TestCase):

    @classmethod
    def setUpClass(cls):
        rospy.init_node('test_operations')
        cls.status = Recorder('battery_status')
        cls.state = Recorder('battery_simulator/state', BatterySimState)
        cls.diagnostics = Recorder('/diagnostics', DiagnosticArray)
        cls.aggregated = Recorder('/diagnostics_agg', DiagnosticArray)
        for service in ('set_state', 'reset', 'inject_fault'):
            rospy.wait_for_service('battery_simulator/' + service, 30.0)
        cls.set_state = SetStateProxy('battery_simulator/set_state')
        cls.reset = rospy.ServiceProxy('battery_simulator/reset', Trigger)
        cls.inject = rospy.ServiceProxy('battery_simulator/inject_fault', InjectFault)
        cls.client = actionlib.SimpleActionClient('battery_simulator', battery_simAction)
        assert cls.client.wait_for_server(rospy.Duration(30.0)), 'Could not connect to battery_simulator'
        cls.reconfigure = ReconfigureClient('BatterySimServer', timeout=30.0)
        wait_for(lambda: cls.status.count() > 0, 30.0, 'battery_status')

    def setUp(self):
        for fault in ('charger_fault', 'overheat', 'sensor_dropout', 'measurement_noise'):
            self.inject(fault, False)
        rospy.set_param(MODE_PARAM, 0)
        self.assertTrue(self.set_state(80.0, 25.0, NAN).success)

    def battery_diagnostic(self, predicate, what, timeout_s=5.0):
        seen = self.diagnostics.count()
        found = self.diagnostics.wait_new(
            seen, lambda a: battery_status_of(a) is not None and predicate(battery_status_of(a)), timeout_s, what)
        return battery_status_of(found)

    # -- diagnostics -----------------------------------------------------------

    def test_diagnostics_have_the_keys_and_levels_and_aggregate_under_power_system(self):
        ok = self.battery_diagnostic(lambda s: s.level == DiagnosticStatus.OK, 'an OK battery status')
        self.assertTrue(ok.name.startswith(rospy.resolve_name('battery_state_pub').lstrip('/')), ok.name)
        self.assertEqual([v.key for v in ok.values], KEYS)
        values = {v.key: v.value for v in ok.values}
        self.assertTrue(ok.hardware_id.startswith('SIM-3S1P-0001'), ok.hardware_id)   # + '-<robot>' in a fleet
        self.assertEqual(values['Charging State'], 'Discharging')
        self.assertEqual(values['Health'], 'Good')
        self.assertGreater(float(values['Time Remaining (min)']), 0.0)
        self.assertTrue(0.0 <= float(values['Percentage (%)']) <= 100.0)
        seen = self.aggregated.count()
        # the shipped analyzers: /Power System/Battery in the root namespace, "robot1 battery_state_pub: Battery"
        # (the aggregator turns the status name's slash into a space) under it in a namespace or a fleet
        namespace = rospy.get_namespace().strip('/')
        expected = '/Power System/' + ('%s battery_state_pub: Battery' % namespace if namespace else 'Battery')
        self.aggregated.wait_new(seen, lambda a: any(s.name == expected for s in a.status), 10.0,
                                 '%s on /diagnostics_agg' % expected)
        self.set_state(15.0, NAN, NAN)
        warn = self.battery_diagnostic(lambda s: s.level == DiagnosticStatus.WARN, 'WARN at 15 %')
        self.assertIn('Low', warn.message)
        self.set_state(3.0, NAN, NAN)
        self.battery_diagnostic(lambda s: s.level == DiagnosticStatus.ERROR, 'ERROR at 3 %')
        self.set_state(0.0, NAN, NAN)
        empty = self.battery_diagnostic(lambda s: {v.key: v.value for v in s.values}['Charging State'] == 'Empty',
                                        'Empty')
        self.assertEqual(empty.level, DiagnosticStatus.ERROR)
        self.assertEqual({v.key: v.value for v in empty.values}['Time Remaining (min)'], '')

    def test_diagnostics_come_at_least_once_a_second(self):
        seen = self.diagnostics.count()
        first = self.battery_diagnostic(lambda s: True, 'a battery status')
        self.diagnostics.wait_new(seen + 1, lambda a: battery_status_of(a) is not None, 1.2, 'the next within 1 s')
        self.assertIsNotNone(first)

    # -- test controls -----------------------------------------------------------

    def test_set_state_shows_on_the_next_battery_status_and_refuses_bad_values(self):
        seen = self.status.count()
        self.assertTrue(self.set_state(18.0, 35.0, 0.9).success)
        msg = self.status.wait_new(seen, lambda m: abs(m.percentage - 0.18) < 0.002, 1.0, '18 % at once')
        self.assertAlmostEqual(self.status.next_after(self.status.count()).percentage, 0.18, delta=0.002,
                               msg='no older state after it')
        self.assertAlmostEqual(msg.temperature, 35.0, delta=0.5)
        self.assertAlmostEqual(msg.capacity, 0.9 * msg.design_capacity, places=3)
        for bad in ((120.0, NAN, NAN), (-1.0, NAN, NAN), (NAN, 500.0, NAN), (NAN, NAN, 1.5), (50.0, NAN, 0.0)):
            response = self.set_state(*bad)
            self.assertFalse(response.success, 'set_state%r accepted' % (bad,))
            self.assertTrue(response.message)
        after = self.status.next_after(self.status.count())
        self.assertLess(after.percentage, 0.181, 'nothing changed')
        self.assertAlmostEqual(after.capacity, 0.9 * after.design_capacity, places=3)

    def test_reset_returns_to_the_start_up_state_and_keeps_the_mode(self):
        rospy.set_param(MODE_PARAM, 1)
        self.set_state(30.0, 40.0, 0.7)
        self.status.wait_until(lambda m: m.power_supply_status == BatteryState.POWER_SUPPLY_STATUS_CHARGING, 5.0,
                               'charging')
        self.assertTrue(self.reset().success)
        msg = self.status.wait_until(lambda m: m.percentage > 0.85, 5.0, 'the initial 90 %')
        self.assertAlmostEqual(msg.percentage, 0.90, delta=0.01)
        self.assertAlmostEqual(msg.temperature, 25.0, delta=0.5)
        self.assertAlmostEqual(msg.capacity, msg.design_capacity, places=3)
        self.assertEqual(rospy.get_param(MODE_PARAM), 1, 'the mode stays')

    def test_charger_fault_keeps_a_charge_goal_from_succeeding(self):
        self.set_state(50.0, NAN, NAN)
        self.assertTrue(self.inject('charger_fault', True).success)
        self.client.send_goal(battery_simGoal(charge_state=True))
        held = self.status.wait_until(
            lambda m: m.power_supply_status == BatteryState.POWER_SUPPLY_STATUS_NOT_CHARGING, 5.0, 'NOT_CHARGING')
        later = self.state.next_after(self.state.count() + 20)   # 20 updates: 40 simulated seconds
        self.assertEqual(self.client.get_state(), GoalStatus.ACTIVE, 'the charge goal must not succeed')
        self.assertLessEqual(later.battery.percentage, held.percentage, 'the level must not rise')
        self.assertEqual(later.battery.current, 0.0)
        self.inject('charger_fault', False)
        self.status.wait_until(lambda m: m.current > 0 and m.percentage > held.percentage, 5.0,
                               'charging again once the charger is fixed')
        self.assertEqual(self.client.get_state(), GoalStatus.ACTIVE)
        self.client.cancel_goal()
        self.assertTrue(self.client.wait_for_result(rospy.Duration(5.0)))

    def test_overheat_reports_overheat_health(self):
        self.assertTrue(self.inject('overheat', True).success)
        hot = self.status.wait_until(
            lambda m: m.power_supply_health == BatteryState.POWER_SUPPLY_HEALTH_OVERHEAT, 5.0, 'OVERHEAT')
        self.assertGreater(hot.temperature, 60.0)
        self.battery_diagnostic(lambda s: s.level == DiagnosticStatus.WARN and 'Overheat' in s.message, 'WARN Overheat')
        self.inject('overheat', False)

    def test_sensor_dropout_stops_battery_status_and_it_resumes(self):
        self.assertTrue(self.inject('sensor_dropout', True).success)
        self.state.next_after(self.state.count() + 2)
        silent_from = self.status.count()
        self.state.next_after(self.state.count() + 25)   # 0.5 s: about 12 ticks at 25 Hz
        self.assertEqual(self.status.count(), silent_from, 'battery_status went on during sensor_dropout')
        self.assertGreater(self.state.latest().battery.charge, 0, 'the model runs on')
        self.inject('sensor_dropout', False)
        self.status.next_after(silent_from, 5.0)

    def test_measurement_noise_has_the_configured_sigma_and_no_bias(self):
        rospy.delete_param(MODE_PARAM)   # hold: a constant true voltage
        true = self.status.wait_until(lambda m: m.power_supply_status
                                      == BatteryState.POWER_SUPPLY_STATUS_NOT_CHARGING, 5.0, 'holding')
        self.inject('measurement_noise', True)
        start = self.status.count() + 2
        wait_for(lambda: self.status.count() >= start + 200, 30.0, '200 noisy samples')
        samples = self.status.since(start)[:200]
        self.inject('measurement_noise', False)
        rospy.set_param(MODE_PARAM, 0)
        voltages = [m.voltage for m in samples]
        currents = [m.current for m in samples]
        for values, sigma, truth in ((voltages, SIGMA_V, true.voltage), (currents, SIGMA_A, 0.0)):
            self.assertAlmostEqual(statistics.stdev(values), sigma, delta=0.2 * sigma)
            self.assertAlmostEqual(statistics.mean(values), truth, delta=4 * sigma / math.sqrt(len(values)))

    def test_unknown_fault_lists_the_known_ones(self):
        response = self.inject('gremlins', True)
        self.assertFalse(response.success)
        for fault in ('charger_fault', 'overheat', 'sensor_dropout', 'measurement_noise'):
            self.assertIn(fault, response.message)

    # -- dynamic_reconfigure -------------------------------------------------------

    def drain_rate(self, current_a):
        """Charge drawn per second of stamps over 1 s of updates, once the model draws ``current_a``."""
        start = self.state.count()
        first = self.state.wait_new(start, lambda m: abs(m.battery.current + current_a) < 1e-6, 15.0,
                                    'the model drawing %g A' % current_a)
        last = self.state.wait_new(start, lambda m: (m.battery.header.stamp - first.battery.header.stamp).to_sec()
                                   >= 1.0, 10.0, '1 s of updates')
        self.assertEqual(last.charging_state, 'Discharging', 'discharging throughout')
        return (first.battery.charge - last.battery.charge) / (
            last.battery.header.stamp - first.battery.header.stamp).to_sec()

    def tearDown(self):
        self.reconfigure.update_configuration(DEFAULTS)   # whatever a failed test left

    def test_live_tuning_changes_the_model_and_refuses_bad_values(self):
        seen = self.state.count()
        self.set_state(90.0, NAN, NAN)
        self.state.wait_new(seen, lambda m: m.publish_now, 15.0, 'the state set')   # older ones may come late
        before = self.drain_rate(1.5)
        config = self.reconfigure.update_configuration({'load_current_a': 3.0})
        self.assertEqual(config['load_current_a'], 3.0)
        self.assertAlmostEqual(self.drain_rate(3.0) / before, 2.0, delta=0.1, msg='a doubled load doubles the drain')
        config = self.reconfigure.update_configuration({'time_scale': 20.0})
        self.assertAlmostEqual(self.drain_rate(3.0) / before, 4.0, delta=0.2, msg='twice the time scale')
        refused = self.reconfigure.update_configuration({'load_current_a': 500.0})
        self.assertEqual(refused['load_current_a'], 3.0, 'a value beyond the datasheet is refused')
        changes = {'load_power_w': 5.0, 'charge_current_a': 2.0, 'ambient_temperature_c': 30.0,
                   'drive_power_w_per_mps': 40.0, 'turn_power_w_per_radps': 3.0}
        config = self.reconfigure.update_configuration(changes)
        for name, value in changes.items():
            self.assertEqual(config[name], value, name)
        rospy.set_param(MODE_PARAM, 1)
        charging = self.state.wait_until(lambda m: m.charging_state == 'Charging', 5.0, 'charging')
        self.assertAlmostEqual(charging.battery.current, 2.0, places=3)


if __name__ == '__main__':
    rostest.rosrun('battery_simulator', result_name('operations'), TestOperations)
