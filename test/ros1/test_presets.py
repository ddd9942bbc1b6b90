#!/usr/bin/python3
"""rostest: every shipped preset starts at 0, 50 and 100 % on ROS 1 (issue 33, item 2): sim.launch's
battery_sim_server.py and battery_state_pub.py publish battery_status at the level they were given (the
gauge's start error clamped to 0-100 %). On main lg_hg2_7s4p_aged died at 100 % ("gauge at 102.0 %")."""
import unittest

import rospy
import rostest
from sensor_msgs.msg import BatteryState

from battery_simulator.core.config_files import preset, preset_names
from rostest_helpers import Recorder, wait_for

LEVELS = (0, 50, 100)


class TestPresets(unittest.TestCase):

    def test_every_preset_starts_at_0_50_and_100_percent(self):
        rospy.init_node('test_presets')
        recorders = {(name, level): Recorder('/p_%s_%d/battery_status' % (name, level), BatteryState)
                     for name in preset_names() for level in LEVELS}
        try:
            wait_for(lambda: all(r.count() for r in recorders.values()), 120.0, 'battery_status from every preset')
        except AssertionError:
            silent = sorted('%s at %d %%' % key for key, r in recorders.items() if not r.count())
            raise AssertionError('no battery_status from %s (a preset missing from presets.test, or a server '
                                 'that died at start)' % ', '.join(silent)) from None
        for (name, level), recorder in sorted(recorders.items()):
            gauge = preset(name).gauge or {}
            expected = min(100.0, max(0.0, level + gauge.get('initial_error', 0.0)))
            read = 100.0 * recorder.since(0)[0].percentage
            self.assertAlmostEqual(read, expected, delta=0.5, msg='%s at %d %%: battery_status says %.2f %%'
                                   % (name, level, read))


if __name__ == '__main__':
    rostest.rosrun('battery_simulator', 'presets', TestPresets)
