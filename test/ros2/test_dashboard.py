"""battery_dashboard on ROS 2: a fleet of five (battery_fleet) and the dashboard, read through its API and
in headless Chromium, a control through the ROS 2 service, 403 for a foreign Host, a best-effort driver's
battery beside the fleet, one line and a non-zero exit for a bad parameter or a port in use.

The dashboard runs under tools/ros2.sh like every node here; the browser is driven from /usr/bin/python3
(Debian's selenium), reading the page only. Every wait has a bound."""
import http.client
import json
import os
import socket
import subprocess
import time

import pytest
from rclpy.qos import qos_profile_sensor_data
from sensor_msgs.msg import BatteryState

from ros2_probe import NodeProcess, Probe

HERE = os.path.dirname(os.path.abspath(__file__))
ROBOTS = ['robot%d' % k for k in range(5)]
DRIVER_TOPIC = '/zz_driver/battery_status'   # a driver's battery (best effort), sorts after the robots
ROBOT10_TOPIC = '/robot10/battery_status'    # natural order: after robot4, not after robot1
PORTS = range(18500, 18600)                  # this test's dashboards listen here only


def free_port(family=socket.AF_INET, address='127.0.0.1'):
    for port in PORTS:
        with socket.socket(family) as probe_socket:
            try:
                probe_socket.bind((address, port))
                return port
            except OSError:
                continue
    raise AssertionError('no free port in 18500-18599')


def topic_of(robot):
    return '/%s/battery_status' % robot


def request(port, path, host=None, method='GET', body=None):
    connection = http.client.HTTPConnection('127.0.0.1', port, timeout=15.0)
    try:
        connection.putrequest(method, path, skip_host=True)
        connection.putheader('Host', host or '127.0.0.1:%d' % port)
        if body is not None:
            data = json.dumps(body).encode()
            connection.putheader('Content-Type', 'application/json')
            connection.putheader('Content-Length', str(len(data)))
        connection.endheaders(data if body is not None else None)
        response = connection.getresponse()
        return response.status, response.read()
    finally:
        connection.close()


def batteries(port):
    """{topic: battery} from /api/batteries ({} while the dashboard does not answer)."""
    try:
        status, body = request(port, '/api/batteries')
    except OSError:
        return {}
    return {battery['topic']: battery for battery in json.loads(body)['batteries']} if status == 200 else {}


def wait_until(condition, timeout_s, what):
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        value = condition()
        if value:
            return value
        time.sleep(0.1)
    raise AssertionError('%s: not within %g s' % (what, timeout_s))


@pytest.fixture(scope='module')
def probe():
    probe = Probe('dashboard_test_probe')
    yield probe
    probe.close()


@pytest.fixture(scope='module')
def fleet(probe):
    """Five robots at wall speed (levels hold still), battery_status at 1 Hz."""
    process = NodeProcess('battery_fleet', '-p', 'robots:=5', '-p', 'time_scale:=1.0')
    for robot in ROBOTS:
        assert probe.wait_for(topic_of(robot), BatteryState, timeout_s=30.0) is not None, \
            'no battery_status of %s within 30 s:\n%s' % (robot, process.output())
    yield process
    assert process.stop() == 0, 'battery_fleet did not end cleanly:\n' + process.output()


@pytest.fixture(scope='module')
def dashboard(fleet):
    port = free_port()
    process = NodeProcess('battery_dashboard', '-p', 'port:=%d' % port, '-p', 'allow_control:=true',
                          '-p', 'scan_period:=0.5', '-p', 'history_s:=10.0')
    wait_until(lambda: len(set(batteries(port)) & {topic_of(r) for r in ROBOTS}) == len(ROBOTS), 30.0,
               'every robot on the dashboard')
    process.port = port
    yield process
    assert process.stop() == 0, 'battery_dashboard did not end cleanly on SIGINT:\n' + process.output()
    assert 'Traceback' not in process.output(), process.output()


def levels_match(probe, port):
    """Every robot's level on the dashboard within a point of its latest battery_status (None if one is not)."""
    shown = batteries(port)
    for robot in ROBOTS:
        latest = probe.wait_for(topic_of(robot), BatteryState, timeout_s=3.0, since=time.monotonic() - 1.5)
        level = shown.get(topic_of(robot), {}).get('level')
        if latest is None or level is None or abs(level - 100.0 * latest.percentage) > 1.0:
            return None
    return shown


def hosts_named(port):
    """Every robot's battery names its fleet host (None while one does not)."""
    shown = batteries(port)
    hosts = [shown.get(topic_of(robot), {}).get('host') for robot in ROBOTS]
    return shown if all(host == '/battery_fleet' for host in hosts) else None


def test_every_robot_listed_with_the_level_of_its_battery_status(dashboard, probe):
    shown = wait_until(lambda: levels_match(probe, dashboard.port), 15.0,
                       'each level within a point of its battery_status')
    for robot in ROBOTS:
        battery = shown[topic_of(robot)]
        assert battery['fields']['status'] == 'Discharging', battery['fields']
        assert battery['controls'] and not battery['stale'], battery
    # the host is named by the first /battery_fleet/states message the dashboard hears; the levels above
    # may come first from each robot's own battery_status (issue 40 item 15: under load the test read the
    # host before that message and saw ''): wait for it, bounded
    shown = wait_until(lambda: hosts_named(dashboard.port), 15.0, 'every robot naming its fleet host '
                       '/battery_fleet (from the fleet host\'s states)')


def test_the_page_in_chromium_shows_every_robot_in_natural_order(dashboard, probe):
    """A battery of a robot10 beside robot0..robot4: robot10 after robot4 on the page (natural order;
    the plain one put it after robot1)."""
    publisher = probe.node.create_publisher(BatteryState, ROBOT10_TOPIC, 10)
    timer = probe.node.create_timer(0.5, lambda: publisher.publish(
        BatteryState(percentage=0.7, voltage=12.0, current=-1.0, power_supply_status=2)))
    try:
        wait_until(lambda: ROBOT10_TOPIC in batteries(dashboard.port), 15.0, ROBOT10_TOPIC + ' on the dashboard')
        result = subprocess.run(['/usr/bin/python3', os.path.join(HERE, 'dashboard_browser.py'),
                                 'http://127.0.0.1:%d/' % dashboard.port, str(len(ROBOTS) + 1), '30'],
                                capture_output=True, text=True, timeout=120.0, env=dict(os.environ, PYTHONPATH=''))
    finally:
        probe.node.destroy_timer(timer)
        probe.node.destroy_publisher(publisher)
    assert result.returncode == 0, result.stdout + result.stderr
    page = json.loads(result.stdout)
    robots = [topic_of(robot) for robot in ROBOTS]
    assert page['topics'][:len(ROBOTS) + 1] == robots + [ROBOT10_TOPIC], page['topics']
    listed = json.loads(request(dashboard.port, '/api/batteries')[1])['batteries']
    api = [topic for topic in (battery['topic'] for battery in listed) if topic in page['topics']]
    assert api == page['topics'], 'the API and the page in one order: %s / %s' % (api, page['topics'])
    for topic in robots:
        latest = probe.wait_for(topic, BatteryState, timeout_s=3.0)
        fields = page['fields'][topic]
        assert abs(float(fields['percentage'].split()[0]) - 100.0 * latest.percentage) <= 1.0, (topic, fields)
        assert fields['status'] == 'Discharging' and fields['voltage'].endswith(' V'), fields
        assert 'stale' not in page['classes'][topic], page['classes'][topic]
    assert page['errors'] == [], 'the page logged errors: %s' % page['errors']


def test_a_control_calls_the_ros2_service(dashboard, probe):
    topic = topic_of('robot2')
    status, body = request(dashboard.port, '/api/control', method='POST',
                           body={'topic': topic, 'action': 'set_state', 'percentage': 42})
    assert status == 200 and json.loads(body)['success'], (status, body)
    assert probe.wait_for(topic, BatteryState, lambda m: abs(m.percentage - 0.42) < 0.002, 5.0) is not None, \
        'robot2 at 42 % on battery_status'
    wait_until(lambda: abs((batteries(dashboard.port)[topic]['level'] or 0.0) - 42.0) < 0.15, 5.0,
               'robot2 at 42 % on the dashboard')
    status, body = request(dashboard.port, '/api/control', method='POST',
                           body={'topic': topic, 'action': 'set_state', 'state_of_health': 0.001})
    assert status == 400 and '[0.01, 1]' in json.loads(body)['message'], (status, body)


def test_a_foreign_host_gets_403(dashboard):
    assert request(dashboard.port, '/', host='evil.example:%d' % dashboard.port)[0] == 403
    assert request(dashboard.port, '/api/batteries', host='attacker.test')[0] == 403
    assert request(dashboard.port, '/')[0] == 200
    assert request(dashboard.port, '/battery?topic=%2Frobot0%2Fbattery_status')[0] == 200


def test_bad_requests_are_4xx_and_said_on_one_line(dashboard):
    """Issue 40 item 5, through the real server (the venv's tornado 6.6): 100 path traversals and 100
    /static/%00 gave 100 WARN lines and 100 tracebacks with 500. Now each is 400/403/404 and the flood is one
    line (the rest are counted in one line at the end of 10 s)."""
    paths = ['/static/../../../../etc/passwd', '/static/..%2f..%2f..%2fetc%2fpasswd', '/static/%00',
             '/javascript/chart.js/..%2f..%2f..%2fetc%2fshadow', '/static/dashboard.js%00']
    codes = {}
    for _ in range(40):
        for path in paths:
            codes[path] = request(dashboard.port, path)[0]
    assert all(code in (400, 403, 404) for code in codes.values()), codes
    output = dashboard.output()
    assert 'Traceback' not in output and 'Uncaught exception' not in output, output[-3000:]
    said = [line for line in output.splitlines() if 'etc/passwd' in line or 'etc/shadow' in line or '%00' in line]
    assert len(said) <= 1, 'more than one line about the flood:\n' + '\n'.join(said[:10])


def test_host_of_every_ipv6_address_logs_a_url_a_browser_opens():
    port = free_port(socket.AF_INET6, '::')
    # quoted: rcl reads a bare :: as YAML and fails
    process = NodeProcess('battery_dashboard', '-r', '__node:=ipv6_dashboard', '-p', "host:='::'",
                          '-p', 'port:=%d' % port)
    try:
        assert process.wait_for_output('http://[::]:%d/' % port, 30.0), process.output()
        connection = http.client.HTTPConnection('::1', port, timeout=15.0)   # tornado binds :: IPv6 only
        try:
            connection.request('GET', '/', headers={'Host': '[::1]:%d' % port})
            assert connection.getresponse().status == 200
        finally:
            connection.close()
    finally:
        assert process.stop() == 0, process.output()


def test_a_best_effort_driver_beside_the_fleet_is_shown(dashboard, probe):
    publisher = probe.node.create_publisher(BatteryState, DRIVER_TOPIC, qos_profile_sensor_data)
    try:
        def shown():
            publisher.publish(BatteryState(percentage=0.5, voltage=12.0, current=-1.0, power_supply_status=2))
            return batteries(dashboard.port).get(DRIVER_TOPIC, {}).get('level') == 50.0
        wait_until(shown, 15.0, 'a best-effort battery_status at 50 % on the dashboard')
    finally:
        probe.node.destroy_publisher(publisher)


def test_a_fleet_topic_first_seen_by_a_subscriber_is_read_once_its_publisher_comes(dashboard, probe):
    """The dashboard subscribed to a topic the graph knew only from a subscriber (another dashboard, a fleet
    manager) with "best available" QoS, which then takes transient local and never matches the volatile
    fleet host that comes later (the 1000-robot benchmark: not one card in 5 minutes). Now it waits for a
    publisher."""
    from battery_simulator.msg import BatteryFleetState
    topic = '/site/battery_fleet/states'
    listener = probe.node.create_subscription(BatteryFleetState, topic, lambda msg: None, 10)
    publisher = timer = None
    try:
        wait_until(lambda: topic in dict(probe.node.get_topic_names_and_types()), 10.0, topic + ' on the graph')
        time.sleep(1.5)   # three of the dashboard's scans (scan_period 0.5 s) with only a subscriber there
        publisher = probe.node.create_publisher(BatteryFleetState, topic, 10)   # reliable, volatile
        timer = probe.node.create_timer(0.5, lambda: publisher.publish(BatteryFleetState(
            names=['late_robot'], states=[BatteryState(percentage=0.33, voltage=12.0, current=-1.0,
                                                        power_supply_status=2)])))
        wait_until(lambda: abs((batteries(dashboard.port).get('/site/late_robot/battery_status', {}).get('level')
                                or 0.0) - 33.0) < 0.01, 20.0, 'the late fleet host\'s robot at 33 % on the dashboard')
    finally:
        if timer is not None:
            probe.node.destroy_timer(timer)
        if publisher is not None:
            probe.node.destroy_publisher(publisher)
        probe.node.destroy_subscription(listener)


def fatal_lines(process):
    assert process.wait(30.0) not in (None, 0), 'expected a non-zero exit:\n' + process.output()
    output = process.output()
    assert 'Traceback' not in output, output
    return [line for line in output.splitlines() if 'FATAL' in line]


def test_a_bad_parameter_is_one_line_and_a_non_zero_exit():
    fatal = fatal_lines(NodeProcess('battery_dashboard', '-p', 'history_s:=1.0', '-p', 'port:=%d' % free_port()))
    assert len(fatal) == 1 and 'history_s' in fatal[0] and '[10, 86400]' in fatal[0], fatal


def test_a_port_in_use_is_one_line_and_a_non_zero_exit(dashboard):
    fatal = fatal_lines(NodeProcess('battery_dashboard', '-r', '__node:=second_dashboard',
                                    '-p', 'port:=%d' % dashboard.port))
    assert len(fatal) == 1 and 'in use' in fatal[0] and str(dashboard.port) in fatal[0], fatal
