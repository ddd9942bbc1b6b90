"""Issue 42 item 1: a fleet host larger than PARAMETER_SERVICES_UP_TO (100) keeps every robot's names of Parts 3-4
on its own node (action, services, cmd_vel of either type, charger_contact, battery_status, battery_state,
low/critical, the diagnostics status) and sets a robot's mode through set_charging; its figures at 100-1000
robots are tools/ros2_benchmark.py's (docs/performance.md)."""
import time

from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import TwistStamped
from sensor_msgs.msg import BatteryState
from std_msgs.msg import Bool
from std_srvs.srv import SetBool

import pytest

from battery_simulator.action import BatterySim
from battery_simulator.msg import BatteryFleetState
from battery_simulator.srv import Predict
from battery_simulator.ros2.fleet_host import PARAMETER_SERVICES_UP_TO
from ros2_probe import DISCHARGING, LATCHED, NodeProcess, Probe, set_state, status_after

ROBOTS = PARAMETER_SERVICES_UP_TO + 1
CHARGING = BatteryState.POWER_SUPPLY_STATUS_CHARGING


@pytest.fixture(scope='module')
def probe():
    probe = Probe('large_fleet_probe')
    yield probe
    probe.close()


def test_fleet_of_ten_in_one_process(probe):
    process = NodeProcess('battery_fleet', '-p', 'robots:=10', '-p', 'prefix:=fleetbot', '-p', 'time_scale:=50.0')
    try:
        for k in range(10):
            msg = probe.wait_for('/fleetbot%d/battery_status' % k, BatteryState, timeout_s=30.0)
            assert msg is not None, 'fleetbot%d/battery_status:\n%s' % (k, process.output())
        fleet = probe.wait_for('/battery_fleet/states', BatteryFleetState, lambda m: len(m.names) == 10, 10.0)
        assert fleet is not None and sorted(fleet.names) == sorted('fleetbot%d' % k for k in range(10))
        assert probe.set_parameter('/fleetbot3/battery_simulator', 'charging', True).successful
        assert status_after(probe, '/fleetbot3', lambda m: m.power_supply_status == CHARGING, 2.0) is not None
        other = status_after(probe, '/fleetbot4', lambda m: True)
        assert other.power_supply_status == DISCHARGING, 'one robot\'s charging is its own'
        client = probe.action_client(BatterySim, '/fleetbot5/battery_simulator')
        assert set_state(probe, '/fleetbot5', 99.5).success
        result = probe.result(probe.send_goal(client, BatterySim.Goal(charge_state=True)), 60.0)
        assert result.result.battery_status == 'Full'
        # Part 2's live time_scale on every robot (ROS 1: /<name>/BatterySimServer); the host's own time_scale and
        # charging are the robots' start-up values: refused with a reason, never taken and ignored
        assert probe.set_parameter('/fleetbot2/battery_simulator', 'time_scale', 100.0).successful
        refused = probe.set_parameter('/fleetbot2/battery_simulator', 'time_scale', -1.0)
        assert not refused.successful and 'time_scale' in refused.reason, refused
        for name, value in (('time_scale', -1.0), ('time_scale', 100.0), ('time_scale', 'abc'), ('charging', True)):
            refused = probe.set_parameter('/battery_fleet', name, value)
            assert not refused.successful and name in refused.reason, (name, value, refused)
        # predict on a fleet robot (the fleet host's EventsExecutor takes no guard condition: the host ended at its
        # first predict, 'Guard conditions not supported')
        answer = probe.call(Predict, '/fleetbot6/battery_simulator/predict',
                            Predict.Request(duration_s=[600.0], power_w=[10.0]))
        assert answer.success and answer.feasible, answer
        assert len(process.output().splitlines()) < 40, 'a fleet does not log per level'
    finally:
        assert process.stop() == 0, process.output()


def test_a_fleet_over_100_keeps_every_robots_names_and_sets_its_mode_by_set_charging(probe):
    process = NodeProcess('battery_fleet', '-r', '__ns:=/', '-p', 'robots:=%d' % ROBOTS, '-p', 'prefix:=big',
                          '-p', 'time_scale:=1.0')
    last = '/big%d' % (ROBOTS - 1)
    try:
        # battery_status first, for every robot; the action, services and inputs follow, then the host says ready
        assert probe.wait_for(last + '/battery_status', BatteryState, timeout_s=90.0) is not None, process.output()
        assert process.wait_for_output('battery_fleet ready', 90.0), process.output()[-2000:]
        topic_names = [last + '/' + name for name in ('battery_status', 'battery_state', 'battery_low',
                                                      'battery_critical', 'cmd_vel', 'charger_contact',
                                                      'battery_simulator/_action/status')]
        service_names = [last + '/battery_simulator/' + name for name in (
            'set_load', 'set_charging', 'set_state', 'reset', 'inject_fault', 'predict', '_action/send_goal')]
        # the host says ready once its endpoints exist; DDS announces its last ones to this process a moment later
        deadline = time.monotonic() + 10.0
        while True:
            topics = dict(probe.node.get_topic_names_and_types())
            services = dict(probe.node.get_service_names_and_types())
            if all(name in topics for name in topic_names) and all(name in services for name in service_names) \
                    or time.monotonic() > deadline:
                break
            time.sleep(0.1)
        for name in topic_names:
            assert name in topics, '%s missing' % name
        for name in service_names:
            assert name in services, '%s missing' % name
        assert probe.wait_for(last + '/battery_low', Bool, timeout_s=10.0, qos=LATCHED) is not None
        diagnostics = probe.wait_for('/diagnostics', DiagnosticArray, lambda m: any(
            s.name == last.strip('/') + '/battery_state_pub: Battery' for s in m.status), 10.0)
        assert diagnostics is not None, 'no diagnostics status %s/battery_state_pub: Battery' % last
        fleet = probe.wait_for('/battery_fleet/states', BatteryFleetState, lambda m: len(m.names) == ROBOTS, 10.0)
        assert fleet is not None
        # the mode, per robot, through set_charging
        assert probe.call(SetBool, last + '/battery_simulator/set_charging', SetBool.Request(data=True)).success
        since = time.monotonic()
        assert probe.wait_for(last + '/battery_status', BatteryState, lambda m: m.power_supply_status == CHARGING,
                              5.0, since=since) is not None
        other = probe.wait_for('/big0/battery_status', BatteryState, since=time.monotonic(), timeout_s=5.0)
        assert other.power_supply_status != CHARGING, 'one robot\'s mode is its own'
        # cmd_vel of Nav2 Kilted's type is taken on a shared node too
        publisher = probe.node.create_publisher(TwistStamped, '/big3/cmd_vel', 1)
        try:
            assert process.wait_for_output('/big3/cmd_vel: taking geometry_msgs/TwistStamped', 15.0), \
                process.output()[-2000:]
        finally:
            probe.node.destroy_publisher(publisher)
        client = probe.action_client(BatterySim, last + '/battery_simulator')
        for attempt in range(3):   # a new client's first answer can be lost before the server's writer matched
            try:               # its reader (DDS, volatile): asked again, the later goal preempts the first
                assert probe.send_goal(client, BatterySim.Goal(charge_state=True)).accepted
                break
            except AssertionError:
                if attempt == 2:
                    raise
        # no node per robot: the host's time_scale is every robot's, checked (all or none)
        refused = probe.set_parameter('/battery_fleet', 'time_scale', -1.0)
        assert not refused.successful and 'time_scale' in refused.reason, refused
        assert probe.set_parameter('/battery_fleet', 'time_scale', 2.0).successful
    finally:
        assert process.stop() == 0, process.output()[-2000:]


def test_the_fleets_states_follow_the_hosts_namespace_as_on_ros1(probe):
    """core/fleet.py's FLEET_STATES is relative on both ROS versions: a host under -r __ns:=/site publishes
    /site/battery_fleet/states (ROS 2's was absolute: /battery_fleet/states whatever the namespace)."""
    process = NodeProcess('battery_fleet', '-r', '__ns:=/site', '-p', 'robots:=2', '-p', 'prefix:=nsfleet')
    try:
        fleet = probe.wait_for('/site/battery_fleet/states', BatteryFleetState, lambda m: len(m.names) == 2, 60.0)
        assert fleet is not None, process.output()[-2000:]
        assert sorted(fleet.names) == ['nsfleet0', 'nsfleet1']
    finally:
        assert process.stop() == 0, process.output()[-2000:]

