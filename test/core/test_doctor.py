"""battery_doctor's rules (core/doctor.py), with no ROS: each finding, its fix, and a clean graph."""
import math

import pytest

from battery_simulator.core.doctor import (BEST_EFFORT, EXIT_CLEAN, EXIT_FOUND, RELIABLE, TRANSIENT_LOCAL,
                                           VOLATILE, Endpoint, Graph, Sample, findings, listing, report,
                                           UsageError, parse_arguments, topic_of_interest)

BATTERY = 'sensor_msgs/msg/BatteryState'
TWIST = 'geometry_msgs/msg/Twist'
STAMPED = 'geometry_msgs/msg/TwistStamped'


def endpoint(node, type_name=BATTERY, reliability=RELIABLE, durability=VOLATILE, depth=10):
    return Endpoint(node, type_name, reliability, durability, depth)


def clean_graph():
    """A battery_sim in /robot1 with a docking server reading battery_status, and a Twist teleop."""
    graph = Graph()
    status = graph.topic('/robot1/battery_status')
    status.publishers.append(endpoint('/robot1/battery_state_pub'))
    status.subscribers.append(endpoint('/robot1/docking_server', depth=1))
    status.samples += [Sample(0.8, -1.5, 2), Sample(0.79, -1.5, 2)]
    status.heard = status.sampled_s = 3.0     # the sampler heard every publisher for its whole window
    cmd_vel = graph.topic('/robot1/cmd_vel')
    cmd_vel.publishers.append(endpoint('/robot1/teleop', TWIST))
    cmd_vel.subscribers.append(endpoint('/robot1/battery_simulator', TWIST, depth=1))
    return graph


def problems_of(graph):
    found = findings(graph)
    assert all(line.startswith('problem: ') for line in found), found
    return found


def test_clean_graph_has_no_finding_and_exit_0():
    lines, status = report(clean_graph())
    assert status == EXIT_CLEAN and not problems_of(clean_graph()), lines
    assert lines[-1] == 'no problems found', lines


def test_listing_names_every_battery_publisher_and_subscriber_with_type_and_qos():
    lines = listing(clean_graph())
    text = '\n'.join(lines)
    assert ('publisher   /robot1/battery_status  %s  /robot1/battery_state_pub (reliable, volatile, depth 10)'
            % BATTERY) in lines, text
    assert ('subscriber  /robot1/battery_status  %s  /robot1/docking_server (reliable, volatile, depth 1)'
            % BATTERY) in lines, text
    assert 'subscriber  /robot1/cmd_vel  %s  /robot1/battery_simulator' % TWIST in text, text
    assert 'percentage 0.79, current -1.5 A, DISCHARGING' in text, text


def test_ros1_listing_says_there_is_no_qos_and_no_qos_finding():
    graph = clean_graph()
    graph.has_qos = False
    graph.topics['/robot1/battery_status'].publishers[0] = Endpoint('/robot1/battery_state_pub',
                                                                    'sensor_msgs/BatteryState')
    assert 'QoS (ROS 1: no QoS)' in listing(graph)
    assert problems_of(graph) == []


def test_subscribed_battery_topic_nobody_publishes_names_the_remap():
    graph = clean_graph()
    graph.topic('/robot1/battery_state').subscribers.append(endpoint('/robot1/docking_server', depth=1))
    found = problems_of(graph)
    assert len(found) == 1, found
    assert found[0].startswith('problem: /robot1/battery_state: subscribed by /robot1/docking_server'), found
    assert 'remap /robot1/battery_state:=/robot1/battery_status for /robot1/docking_server' in found[0], found
    assert 'battery_state_topic parameter' in found[0], found


def test_unpublished_battery_topic_prefers_the_battery_of_its_own_namespace():
    graph = clean_graph()
    graph.topic('/robot2/battery_status').publishers.append(endpoint('/robot2/battery_state_pub'))
    graph.topic('/robot2/battery_state').subscribers.append(endpoint('/robot2/docking_server'))
    found = problems_of(graph)
    assert len(found) == 1 and 'remap /robot2/battery_state:=/robot2/battery_status' in found[0], found


def test_unpublished_battery_topic_with_no_battery_anywhere_says_start_one():
    graph = Graph()
    graph.topic('/robot1/battery_state').subscribers.append(endpoint('/robot1/docking_server'))
    found = problems_of(graph)
    assert len(found) == 1 and 'no battery publishes on the graph' in found[0] and '__ns:=/robot1' in found[0], found


def test_twist_stamped_publisher_and_twist_only_subscriber():
    graph = clean_graph()
    graph.topic('/robot1/cmd_vel').publishers[0] = endpoint('/robot1/controller_server', STAMPED)
    found = problems_of(graph)
    assert len(found) == 1, found
    assert found[0].startswith('problem: /robot1/cmd_vel: /robot1/controller_server publishes '
                               'geometry_msgs/TwistStamped, /robot1/battery_simulator subscribes '
                               'geometry_msgs/Twist only'), found
    assert 'enable_stamped_cmd_vel: false' in found[0], found


def test_twist_publisher_and_twist_stamped_only_subscriber():
    graph = clean_graph()
    graph.topic('/robot1/cmd_vel').subscribers[0] = endpoint('/robot1/battery_simulator', STAMPED)
    found = problems_of(graph)
    assert len(found) == 1 and 'publishes geometry_msgs/Twist, ' in found[0], found
    assert 'enable_stamped_cmd_vel: true' in found[0], found


def test_a_subscriber_taking_both_velocity_types_matches_either():
    graph = clean_graph()
    cmd_vel = graph.topic('/robot1/cmd_vel')
    cmd_vel.publishers.append(endpoint('/robot1/controller_server', STAMPED))
    cmd_vel.subscribers.append(endpoint('/robot1/battery_simulator', STAMPED))
    assert problems_of(graph) == []


@pytest.mark.parametrize('sent', ['geometry_msgs/TwistStamped', 'geometry_msgs/Twist'])
def test_a_ros1_subscriber_of_any_type_takes_either(sent):
    """ROS 1's battery takes cmd_vel as rospy.AnyMsg (its node reports the type '*') and drains under either
    type: Nav2's TwistStamped reaching it is no mismatch."""
    graph = Graph(has_qos=False)
    cmd_vel = graph.topic('/cmd_vel')
    cmd_vel.publishers.append(Endpoint('/controller_server', sent))
    cmd_vel.subscribers.append(Endpoint('/BatterySimServer', '*'))
    assert problems_of(graph) == []


def test_reliable_subscriber_and_best_effort_publisher():
    graph = clean_graph()
    graph.topic('/robot1/battery_status').publishers[0] = endpoint('/robot1/battery_state_pub',
                                                                   reliability=BEST_EFFORT)
    found = problems_of(graph)
    assert len(found) == 1, found
    assert ('problem: /robot1/battery_status: QoS cannot match: /robot1/docking_server subscribes reliable, '
            '/robot1/battery_state_pub publishes best_effort') in found[0], found


def test_transient_local_subscriber_and_volatile_publisher():
    graph = clean_graph()
    graph.topic('/robot1/battery_status').subscribers[0] = endpoint('/robot1/docking_server',
                                                                    durability=TRANSIENT_LOCAL)
    found = problems_of(graph)
    assert len(found) == 1 and 'subscribes transient_local' in found[0] and 'publishes volatile' in found[0], found


def test_best_effort_subscriber_of_a_reliable_publisher_matches():
    graph = clean_graph()
    graph.topic('/robot1/battery_status').subscribers[0] = endpoint('/robot1/docking_server',
                                                                    reliability=BEST_EFFORT)
    assert problems_of(graph) == []


def test_percentage_above_1():
    graph = clean_graph()
    graph.topic('/robot1/battery_status').samples.append(Sample(85.0, -1.5, 2))
    found = problems_of(graph)
    assert len(found) == 1 and found[0].startswith('problem: /robot1/battery_status: percentage 85 is above 1'), \
        found
    assert 'divide by 100' in found[0], found


def test_percentage_of_exactly_1_and_nan_are_fine():
    graph = clean_graph()
    graph.topic('/robot1/battery_status').samples += [Sample(1.0, 0.0, 4), Sample(math.nan, math.nan, 0)]
    assert problems_of(graph) == []


def test_charging_with_a_negative_current():
    graph = clean_graph()
    graph.topic('/robot1/battery_status').samples.append(Sample(0.5, -2.0, 1))
    found = problems_of(graph)
    assert len(found) == 1, found
    assert found[0].startswith('problem: /robot1/battery_status: current -2 A is negative while '
                               'power_supply_status is CHARGING'), found
    assert 'invert_current_sign' in found[0], found


def test_discharging_with_a_positive_current():
    graph = clean_graph()
    graph.topic('/robot1/battery_status').samples.append(Sample(0.5, 3.0, 2))
    found = problems_of(graph)
    assert len(found) == 1 and 'is positive while power_supply_status is DISCHARGING' in found[0], found


def test_current_within_the_noise_band_contradicts_nothing():
    graph = clean_graph()
    graph.topic('/robot1/battery_status').samples += [Sample(0.5, 0.01, 2), Sample(1.0, -0.01, 1)]
    assert problems_of(graph) == []


def test_two_nodes_publishing_one_battery():
    graph = clean_graph()
    graph.topic('/robot1/battery_status').publishers.append(endpoint('/robot1/other_battery'))
    found = problems_of(graph)
    assert len(found) == 1, found
    assert found[0].startswith('problem: /robot1/battery_status: 2 publishers publish this battery '
                               '(/robot1/battery_state_pub, /robot1/other_battery)'), found


def gid_endpoint(node, gid):
    return Endpoint(node, BATTERY, RELIABLE, VOLATILE, 10, gid)


def test_three_publishers_sharing_a_node_name_are_three():
    """Issue 40 item 4: counted by node name they were one, and nothing was said."""
    graph = clean_graph()
    status = graph.topic('/robot1/battery_status')
    status.publishers[:] = [gid_endpoint('/robot1/battery_state_pub', gid) for gid in ('0a', '0b', '0c')]
    status.samples[:] = [Sample(0.8, -1.5, 2, 12.0, gid) for gid in ('0a', '0b', '0c')]
    found = problems_of(graph)
    assert found == ['problem: /robot1/battery_status: 3 publishers publish this battery (/robot1/battery_state_pub '
                     '(3 publishers)): a reader sees their readings interleaved; give each battery its own namespace '
                     '(__ns:=/robotN) or stop all but one'], found


@pytest.mark.parametrize('voltage', [math.nan, -1.0, math.inf])
def test_a_voltage_out_of_its_range_is_named(voltage):
    graph = clean_graph()
    graph.topic('/robot1/battery_status').samples.append(Sample(0.8, -1.5, 2, voltage))
    found = problems_of(graph)
    assert len(found) == 1 and found[0].startswith('problem: /robot1/battery_status: voltage %s is out of its range'
                                                   % ('NaN' if math.isnan(voltage) else '%.3g' % voltage)), found


def test_a_percentage_below_0_is_named_and_nan_and_0_are_not():
    graph = clean_graph()
    graph.topic('/robot1/battery_status').samples += [Sample(math.nan, -1.5, 2, 12.0), Sample(0.0, -1.5, 2, 12.0)]
    assert problems_of(graph) == []
    graph.topic('/robot1/battery_status').samples.append(Sample(-1.0, -1.5, 2, 12.0))
    found = problems_of(graph)
    assert len(found) == 1 and found[0].startswith('problem: /robot1/battery_status: percentage -1 is below 0'), found


def test_a_publisher_heard_for_the_whole_window_that_sent_nothing_went_silent():
    graph = clean_graph()
    status = graph.topic('/robot1/battery_status')
    status.publishers[:] = [gid_endpoint('/robot1/battery_state_pub', '0a'), gid_endpoint('/robot1/driver', '0b')]
    status.samples[:] = [Sample(0.8, -1.5, 2, 12.0, '0a')]
    found = [line for line in problems_of(graph) if 'publishers publish' not in line]
    assert found == ['problem: /robot1/battery_status: /robot1/driver sent nothing in 3.0 s of sampling (connected): '
                     'it went silent (a hung driver, a stopped timer), publishes slower than that, or has not matched '
                     'this doctor yet (a host busy with discovery): restart it, or give a longer --sample'], found
    alone = clean_graph()
    alone.topic('/robot1/battery_status').samples[:] = []
    found = problems_of(alone)
    assert len(found) == 1 and '/robot1/battery_state_pub sent nothing in 3.0 s' in found[0], found
    lines, status_code = report(alone)
    assert status_code == EXIT_FOUND and lines[-1] == '1 problem(s) found', lines


def test_a_topic_not_heard_out_is_listed_unsampled_on_its_own_line_and_exits_1():
    """Issue 40 item 4: 73 of 200 topics unsampled and still 'no problems found'."""
    graph = clean_graph()
    for k, (heard, samples) in enumerate(((None, []), (1.0, []), (None, [Sample(0.5, -1.0, 2, 12.0, 'a')]),
                                          (None, [Sample(0.5, -1.0, 2, 12.0, 'b')]))):
        topic = graph.topic('/robot%d/battery_status' % (k + 2))
        topic.publishers += [gid_endpoint('/robot%d/battery_state_pub' % (k + 2), 'a'),
                             gid_endpoint('/robot%d/battery_state_pub' % (k + 2), 'b')][:1 + (k >= 2)]
        topic.samples += samples
        topic.heard, topic.sampled_s = heard, 3.0
    graph.topic('/robot9/battery_status').publishers.append(endpoint('/robot9/battery_state_pub'))   # never tried
    graph.topics['/robot5/battery_status'].publishers.pop(0)   # its one publisher heard: sampled
    lines, status_code = report(graph)
    assert status_code == EXIT_FOUND and [line for line in lines if line.startswith('problem:')] == [
        'problem: /robot4/battery_status: 2 publishers publish this battery (/robot4/battery_state_pub (2 publishers)):'
        ' a reader sees their readings interleaved; give each battery its own namespace (__ns:=/robotN) or stop all '
        'but one'], lines
    missed = [line for line in lines if line.startswith('unsampled:')]
    assert missed == ['unsampled: 4 battery topic(s) not heard out, so not checked: /robot2/battery_status (not '
                      'connected to every publisher), /robot3/battery_status (connected for 1.0 s of 3.0), '
                      '/robot4/battery_status (not connected to every publisher), /robot9/battery_status (not '
                      'sampled): give a longer --sample (or --wait)'], lines
    assert lines[-1] == '1 problem(s) found, 4 battery topic(s) unsampled' and 'no problems found' not in lines


def test_several_problems_one_line_each_and_exit_1():
    graph = clean_graph()
    graph.topic('/robot1/battery_state').subscribers.append(endpoint('/robot1/docking_server'))
    graph.topic('/robot1/cmd_vel').publishers[0] = endpoint('/robot1/controller_server', STAMPED)
    graph.topic('/robot1/battery_status').samples.append(Sample(85.0, -2.0, 1))
    lines, status = report(graph)
    problems = [line for line in lines if line.startswith('problem:')]
    assert status == EXIT_FOUND and len(problems) == 4, lines
    assert lines[-1] == '4 problem(s) found', lines


def test_topics_of_interest_by_type_or_name():
    assert topic_of_interest('/x', [BATTERY]) and topic_of_interest('/y', ['sensor_msgs/BatteryState'])
    assert topic_of_interest('/robot1/cmd_vel', ['std_msgs/msg/String'])
    assert topic_of_interest('/nav/out', [STAMPED])
    assert not topic_of_interest('/robot1/odom', ['nav_msgs/msg/Odometry'])


def test_command_line():
    assert parse_arguments([]) == {'wait': 2.0, 'sample': 3.0}
    assert parse_arguments(['--wait', '0.5', '--sample=1']) == {'wait': 0.5, 'sample': 1.0}
    for bad, named in ((['--wait', '-1'], '--wait -1'), (['--wait', 'nan'], '--wait nan'), (['--sample'], '--sample'),
                       (['--frobnicate'], '--frobnicate'), (['extra'], 'extra'), (['--wait', '61'], '--wait 61')):
        with pytest.raises(UsageError) as error:
            parse_arguments(bad)
        assert named in str(error.value) and '\n' not in str(error.value), (bad, str(error.value))


def test_a_discovery_still_finding_endpoints_is_never_no_problems_found():
    """Issue 40 item 4: on a busy machine the ROS 2 doctor had found 98 of a 100-robot host's 200 battery topics
    when its wait ended, and said "no problems found" about them. A discovery still finding endpoints when the
    doctor stops is a line of its own, counted (exit 1)."""
    graph = clean_graph()
    graph.discovering_s = 13.2
    lines, code = report(graph)
    assert code == EXIT_FOUND and 'no problems found' not in lines, lines
    assert [line for line in lines if line.startswith('undiscovered: ')] == [
        'undiscovered: discovery was still finding endpoints after 13.2 s, so the graph may be larger than shown: '
        'give a longer --wait'], lines
    assert lines[-1] == '0 problem(s) found, discovery unfinished', lines
