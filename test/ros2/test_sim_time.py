"""battery_sim under use_sim_time (ROS 2 twin of test/ros1/sim_time.test): the first /clock value is a start,
a clock that jumps back restarts the time base and battery_status flows on."""
import time

from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import BatteryState

from ros2_probe import NodeProcess, status_after


def test_sim_time_backwards_jump_restarts_the_time_base(probe):
    clock = probe.node.create_publisher(Clock, '/clock', 10)

    def tick(seconds):
        clock.publish(Clock(clock=probe.node.get_clock().now().__class__(seconds=seconds).to_msg()))

    process = NodeProcess('battery_sim', '-r', '__ns:=/simtime', '-p', 'use_sim_time:=true',
                          '-p', 'initial_percentage:=80.0')
    try:
        assert probe.wait_for('/simtime/battery_status', BatteryState, timeout_s=20.0) is not None, process.output()
        for seconds in (1.7e9, 1.7e9 + 0.5):
            tick(seconds)
            time.sleep(0.3)
        start = status_after(probe, '/simtime', lambda m: True).percentage
        assert abs(start - 0.80) < 0.002, 'the first /clock value is a start, not elapsed time (%g)' % start
        tick(100.0)   # back: a restart, nothing drained
        time.sleep(0.3)
        tick(101.0)
        time.sleep(0.3)
        after = status_after(probe, '/simtime', lambda m: True)
        assert after is not None, 'battery_status keeps flowing after the jump'
        assert abs(after.percentage - start) < 0.002, 'the jump drained nothing (%g -> %g)' % (start, after.percentage)
        tick(401.0)   # 300 s at 1.5 A of 3 Ah: about 4 points
        time.sleep(0.5)
        later = status_after(probe, '/simtime', lambda m: True)
        assert 0.02 < start - later.percentage < 0.07, (start, later.percentage)
        assert 'moved backwards' in process.output()
    finally:
        probe.node.destroy_publisher(clock)
        assert process.stop() == 0, process.output()
