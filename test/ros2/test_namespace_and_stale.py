"""battery_state_pub in a namespace of its own, without a battery_sim (ROS 2 twin of
test/ros1/namespace_and_stale.test): alone, it runs a battery of its own (the tutorial node)."""
from sensor_msgs.msg import BatteryState

from ros2_probe import DISCHARGING, NodeProcess


def test_tutorial_node_alone_runs_a_battery(probe):
    process = NodeProcess('battery_state_pub', '-r', '__ns:=/tutorial', '-p', 'wait_s:=0.5',
                          '-p', 'time_scale:=500.0')
    try:
        first = probe.wait_for('/tutorial/battery_status', BatteryState, timeout_s=20.0)
        assert first is not None, process.output()
        later = probe.wait_for('/tutorial/battery_status', BatteryState,
                               lambda m: m.percentage < first.percentage - 0.001, 10.0)
        assert later is not None and later.power_supply_status == DISCHARGING, 'alone, its battery discharges'
        assert later.voltage > 9.0, 'a physical pack voltage (3 cells), not the tutorial\'s decaying 9 V'
        assert 'a battery of its own' in process.output()
    finally:
        assert process.stop() == 0, process.output()
