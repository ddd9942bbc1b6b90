"""battery_doctor (ROS 2) beside a live graph: clean with a battery_sim and a correct reader (exit 0);
each of ten planted faults (a battery of its own in /r7: battery_sim publishes battery_state too once Part 7 lands) named on a 'problem:' line of its own (exit 1).

The doctor sees the whole ROS domain (the conftest gives this run one of its own), so the clean graph
is checked before the planted one starts, and the planted one is stopped at the end of its test."""
import os
import re
import time

import pytest
from sensor_msgs.msg import BatteryState

from ros2_probe import NodeProcess, Probe

HERE = os.path.dirname(os.path.abspath(__file__))
PLANTER = os.path.join(HERE, 'doctor_planted.py')


@pytest.fixture
def probe():
    """A probe of each test's own: its subscriptions end with the test (the doctor would see them)."""
    probe = Probe('doctor_test_probe')
    yield probe
    probe.close()


def run_doctor(*args, timeout_s=30.0):
    doctor = NodeProcess('battery_doctor', args=args)
    code = doctor.wait(timeout_s)
    if code is None:
        doctor.stop()
        raise AssertionError('battery_doctor did not end within %g s:\n%s' % (timeout_s, doctor.output()))
    return code, doctor.output()


def problems(output):
    return [line for line in output.splitlines() if line.startswith('problem:')]


def started(*specs):
    process = NodeProcess('python3', args=(PLANTER,) + specs)   # (its log goes to /tmp, named python3_*)
    assert process.wait_for_output('ready', 20.0), 'planter did not start:\n' + process.output()
    return process


def test_bad_command_line_is_one_line_and_exit_2():
    code, output = run_doctor('--wait', 'soon')
    assert code == 2 and output.strip() == \
        'battery_doctor: --wait soon: must be a number of seconds in (0, 60]', (code, output)


def test_a_battery_sim_with_a_correct_reader_is_clean(probe):
    sim = NodeProcess('battery_sim', '-r', '__ns:=/clean')
    reader = started('sub,node=docking_server,ns=/clean,topic=battery_status,type=BatteryState,depth=1')
    try:
        assert probe.wait_for('/clean/battery_status', BatteryState, timeout_s=20.0) is not None, \
            'no battery_status from battery_sim:\n' + sim.output()
        code, output = run_doctor('--sample', '3')
        assert code == 0 and not problems(output), 'doctor not clean (exit %s):\n%s' % (code, output)
        assert re.search(r'^publisher +/clean/battery_status +sensor_msgs/msg/BatteryState +/clean/battery_state_pub '
                         r'\(reliable, volatile', output, re.M), output
        assert re.search(r'^subscriber +/clean/battery_status +sensor_msgs/msg/BatteryState +/clean/docking_server '
                         r'\(reliable, volatile', output, re.M), output
        assert re.search(r'^subscriber +/clean/cmd_vel +geometry_msgs/msg/Twist +/clean/battery_simulator', output,
                         re.M), output
        assert re.search(r'^sampled +/clean/battery_status +[1-9]', output, re.M), output
        assert output.rstrip().endswith('no problems found'), output
    finally:
        reader.stop()
        assert sim.stop() == 0, sim.output()


def test_each_planted_mismatch_is_named(probe):
    sim = NodeProcess('battery_sim', '-r', '__ns:=/r1')
    # one process per side of a type mismatch: a DDS participant holds one type per topic
    first = started(
        'pub,node=battery_state_pub,ns=/r7,topic=battery_status,type=BatteryState',
        'pub,node=controller_server,ns=/r2,topic=cmd_vel,type=TwistStamped',
        'pub,node=gz_bridge,ns=/r3,topic=battery_status,type=BatteryState,reliability=best_effort',
        'pub,node=battery_state_broadcaster,ns=/r4,topic=battery_status,type=BatteryState,percentage=85',
        'pub,node=inverted_driver,ns=/r5,topic=battery_status,type=BatteryState,current=-2.0,status=1',
        'pub,node=battery_a,ns=/r6,topic=battery_status,type=BatteryState',
        # issue 40 item 4: three publishers sharing one node name, NaN voltage, percentage -1, a silent one
        'pub,node=battery_state_pub,ns=/r8,topic=battery_status,type=BatteryState',
        'pub,node=battery_state_pub,ns=/r8,topic=battery_status,type=BatteryState',
        'pub,node=battery_state_pub,ns=/r8,topic=battery_status,type=BatteryState',
        'pub,node=nan_driver,ns=/r9,topic=battery_status,type=BatteryState,voltage=nan',
        'pub,node=sentinel_driver,ns=/r10,topic=battery_status,type=BatteryState,percentage=-1',
        'pub,node=hung_driver,ns=/r11,topic=battery_status,type=BatteryState,silent_after=2')
    second = started(
        'sub,node=docking_server,ns=/r7,topic=battery_state,type=BatteryState,depth=1',
        'sub,node=base_driver,ns=/r2,topic=cmd_vel,type=Twist',
        'sub,node=docking_server,ns=/r3,topic=battery_status,type=BatteryState,depth=1',
        'pub,node=battery_b,ns=/r6,topic=battery_status,type=BatteryState')
    try:
        assert probe.wait_for('/r1/battery_status', BatteryState, timeout_s=20.0) is not None, sim.output()
        code, output = run_doctor('--sample', '3')
        found = problems(output)
        assert code == 1, 'exit %s:\n%s' % (code, output)

        def named(*words):
            return [line for line in found if all(word in line for word in words)]
        expected = {
            'unpublished': ('problem: /r7/battery_state:', '/r7/docking_server',
                            'remap /r7/battery_state:=/r7/battery_status'),
            'type': ('problem: /r2/cmd_vel:', '/r2/controller_server publishes geometry_msgs/TwistStamped',
                     '/r2/base_driver subscribes geometry_msgs/Twist only', 'enable_stamped_cmd_vel'),
            'qos': ('problem: /r3/battery_status:', 'QoS', '/r3/docking_server subscribes reliable',
                    '/r3/gz_bridge publishes best_effort'),
            'percentage': ('problem: /r4/battery_status:', 'percentage 85 is above 1'),
            'sign': ('problem: /r5/battery_status:', 'current -2 A is negative', 'CHARGING', 'invert_current_sign'),
            'two': ('problem: /r6/battery_status:', '2 publishers publish', '/r6/battery_a', '/r6/battery_b'),
            'three sharing a name': ('problem: /r8/battery_status:', '3 publishers publish',
                                     '/r8/battery_state_pub (3 publishers)'),
            'NaN voltage': ('problem: /r9/battery_status:', 'voltage NaN is out of its range'),
            'percentage -1': ('problem: /r10/battery_status:', 'percentage -1 is below 0'),
            'silent': ('problem: /r11/battery_status:', '/r11/hung_driver sent nothing in', 'went silent'),
        }
        missing = {kind: words for kind, words in expected.items() if len(named(*words)) != 1}
        assert not missing, 'not named once each: %s\n%s' % (sorted(missing), output)
        assert len(found) == len(expected), 'unexpected findings:\n%s' % output
        assert 'unsampled:' not in output and 'no problems found' not in output, output
        assert re.search(r'^publisher +/r3/battery_status +sensor_msgs/msg/BatteryState +/r3/gz_bridge '
                         r'\(best_effort, volatile', output, re.M), output
    finally:
        second.stop()
        first.stop()
        assert sim.stop() == 0, sim.output()


def test_a_fleet_of_100_is_sampled_topic_by_topic_and_its_one_hung_robot_named(probe):
    """Issue 40 item 4: on 100 robots the doctor left up to 73 of 200 battery topics unsampled and said
    "no problems found" (a topic that sent nothing in its window was simply left out). One node publishing
    200 battery topics at 1 Hz (a fleet host's) and one hung driver beside them (robot100: two messages, then
    nothing): every topic of the 200 sampled (a 'sampled' line each), the hung one named, exit 1. The time
    it took is printed (the 15 s figure is the benchmark's: tools/benchmark_dashboard.py --doctor)."""
    fleet = started('fleet,robots=100', 'pub,node=hung_driver,ns=/robot100,topic=battery_status,type=BatteryState,'
                                        'silent_after=2')
    try:
        assert probe.wait_for('/robot99/battery_state', BatteryState, timeout_s=30.0) is not None, fleet.output()
        began = time.monotonic()
        code, output = run_doctor(timeout_s=90.0)
        took = time.monotonic() - began
        sampled = set(re.findall(r'^sampled +(/robot\d+/battery_stat(?:us|e)) ', output, re.M))
        print('battery_doctor on 201 battery topics: %.1f s, %d sampled' % (took, len(sampled)))
        assert code == 1 and len(sampled) == 200 and 'unsampled:' not in output, \
            'exit %s, %d of 200 sampled in %.1f s:\n%s' % (code, len(sampled), took, output[-3000:])
        assert problems(output) == [line for line in output.splitlines() if line.startswith(
            'problem: /robot100/battery_status: /robot100/hung_driver sent nothing in')], output[-3000:]
    finally:
        fleet.stop()


def test_a_host_still_matching_the_doctors_subscriptions_is_not_called_silent(probe):
    """Issue 40 item 4, on a busy machine: a host of 100 robots works through the doctor's 200 new
    subscriptions one by one, seconds after the doctor sees them matched; the doctor counted its window from
    its own side's match and called the publishers it had not heard yet silent (3 of 200 sampled, the rest
    "sent nothing in 7.9 s"). 20 robots whose host sends on robot K only 0.4 x K s after a subscriber came
    (the last 7.6 s after): every topic sampled, none called silent, exit 0."""
    fleet = started('fleet,robots=20,lag=0.4')
    try:
        assert probe.wait_for('/robot0/battery_status', BatteryState, timeout_s=30.0) is not None, fleet.output()
        code, output = run_doctor(timeout_s=60.0)
        sampled = set(re.findall(r'^sampled +(/robot\d+/battery_stat(?:us|e)) ', output, re.M))
        assert code == 0 and len(sampled) == 40 and not problems(output), \
            'exit %s, %d of 40 sampled:\n%s' % (code, len(sampled), output[-3000:])
    finally:
        fleet.stop()
