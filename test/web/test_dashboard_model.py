"""The dashboard without ROS: topic discovery, the stale and low/critical rules, the text of
each field, histories, and the web app's Host/Origin check and control validation."""
import json
import logging
import math
import time

import pytest

from battery_simulator.web import dashboard_model as model
from battery_simulator.web import dashboard_texts as texts
from battery_simulator.web import topic_discovery as discovery
from battery_simulator.web.dashboard_model import DashboardModel

tornado_testing = pytest.importorskip('tornado.testing')
from battery_simulator.web import dashboard_app as app  # noqa: E402 (needs tornado)

NAN = math.nan
TOPIC = '/robot3/battery_status'


def battery(percentage=0.632, voltage=11.5, current=-1.5, temperature=25.0, charge=1.9, capacity=3.0,
            status=2, health=1):
    return dict(percentage=percentage, voltage=voltage, current=current, temperature=temperature, charge=charge,
                capacity=capacity, design_capacity=3.0, power_supply_status=status, power_supply_health=health,
                location='base', serial_number='S1')


# -- discovery ---------------------------------------------------------------------

PUBLISHED = [
    ('/robot0/battery_status', discovery.BATTERY_TYPE),
    ('/robot0/battery_low', discovery.BOOL_TYPE),
    ('/robot0/battery_critical', discovery.BOOL_TYPE),
    ('/robot0/battery_simulator/state', discovery.SIM_STATE_TYPE),
    ('/robot1/battery_status', discovery.BATTERY_TYPE),
    ('/robot1/battery_low', 'std_msgs/String'),          # not a Bool: not its low level
    ('/real/bms', discovery.BATTERY_TYPE),                   # a driver's own name, alone in its namespace
    ('/real/battery_low', discovery.BOOL_TYPE),
    ('/arm/left', discovery.BATTERY_TYPE),                   # two packs in one namespace: extras belong to neither
    ('/arm/right', discovery.BATTERY_TYPE),
    ('/arm/battery_low', discovery.BOOL_TYPE),
    ('/battery_fleet/states', discovery.FLEET_STATE_TYPE),
    ('/site/battery_fleet_1/states', discovery.FLEET_STATE_TYPE),
    ('/robot0/odom', 'nav_msgs/Odometry'),
    ('/rosout', 'rosgraph_msgs/Log'),
]


def test_discovery_finds_every_battery_state_topic_and_the_extras_beside_it():
    batteries, fleets = discovery.discover(PUBLISHED)
    assert sorted(batteries) == ['/arm/left', '/arm/right', '/real/bms', '/robot0/battery_status',
                                 '/robot1/battery_status']
    assert batteries['/robot0/battery_status'] == {'low': '/robot0/battery_low', 'critical': '/robot0/battery_critical',
                                                   'state': '/robot0/battery_simulator/state'}
    assert batteries['/robot1/battery_status'] == {}
    assert batteries['/real/bms'] == {'low': '/real/battery_low'}
    assert batteries['/arm/left'] == batteries['/arm/right'] == {}
    assert fleets == {'/battery_fleet/states': '/', '/site/battery_fleet_1/states': '/site/'}
    assert discovery.fleet_battery_topic('/site/', 'robot7') == '/site/robot7/battery_status'
    assert discovery.discover([]) == ({}, {})


def test_a_battery_state_twin_of_battery_status_is_one_battery():
    """battery_state_pub publishes battery_state beside battery_status (opennav_docking's name): shown once; a
    battery_state alone (another driver) is a battery of its own."""
    published = [('/robot0/battery_status', discovery.BATTERY_TYPE), ('/robot0/battery_state', discovery.BATTERY_TYPE),
                 ('/other/battery_state', discovery.BATTERY_TYPE), ('/robot0/battery_low', discovery.BOOL_TYPE)]
    batteries, _ = discovery.discover(published)
    assert sorted(batteries) == ['/other/battery_state', '/robot0/battery_status']
    assert batteries['/robot0/battery_status'] == {'low': '/robot0/battery_low'}


def test_namespace_of():
    assert discovery.namespace_of('/robot3/battery_status') == '/robot3/'
    assert discovery.namespace_of('/battery_status') == '/'
    assert discovery.namespace_of('/a/b/c') == '/a/b/'


# -- rules and text ------------------------------------------------------------------

def test_stale_after_three_seconds_or_three_periods_whichever_is_longer():
    assert model.stale_after_s(None) == 3.0
    assert model.stale_after_s(0.1) == 3.0
    assert model.stale_after_s(1.0) == 3.0
    assert model.stale_after_s(5.0) == 15.0
    dashboard = DashboardModel(history_s=600)
    for t in (0.0, 5.0, 10.0):   # a battery publishing every 5 s
        dashboard.on_battery(TOPIC, battery(), t)
    record = dashboard.records[TOPIC]
    assert not record.stale(24.9) and record.stale(25.0)
    fast = '/fast/battery_status'
    for k in range(11):          # 10 Hz: 3 s after the last (at 101 s)
        dashboard.on_battery(fast, battery(), 100.0 + 0.1 * k)
    assert not dashboard.records[fast].stale(103.9) and dashboard.records[fast].stale(104.01)


def test_a_battery_goes_stale_then_leaves_after_history_s_and_the_page_hears_both():
    dashboard = DashboardModel(history_s=60)
    dashboard.add(TOPIC, 0.0)
    dashboard.on_battery(TOPIC, battery(), 0.0)
    dashboard.on_battery(TOPIC, battery(), 1.0)
    changed, removed = dashboard.tick(1.5)
    assert [view['topic'] for view in changed] == [TOPIC] and not changed[0]['stale'] and removed == []
    assert dashboard.tick(2.0) == ([], [])              # nothing new: nothing sent
    changed, removed = dashboard.tick(4.5)
    assert [view['stale'] for view in changed] == [True]
    assert dashboard.tick(30.0) == ([], [])
    assert dashboard.tick(61.5) == ([], [TOPIC])
    assert TOPIC not in dashboard.records and dashboard.snapshot(62.0) == []
    dashboard.on_battery(TOPIC, battery(), 70.0)        # back: shown again, not stale
    assert [(view['topic'], view['stale']) for view in dashboard.tick(70.1)[0]] == [(TOPIC, False)]


def test_nan_fields_show_a_dash():
    assert texts.percentage_text(NAN) == '-'
    assert texts.number_text(NAN, 2, 'V') == '-'
    assert texts.number_text(math.inf, 2, 'V') == '-'
    assert texts.number_text(None, 2, 'V') == '-'
    assert texts.duration_text(NAN) == '-' and texts.duration_text(None) == '-'
    dashboard = DashboardModel(history_s=600)
    dashboard.on_battery(TOPIC, battery(percentage=NAN, voltage=NAN, current=NAN, temperature=NAN, charge=NAN,
                                        capacity=NAN, status=0, health=0), 0.0)
    view = dashboard.snapshot(0.5)[0]
    assert set(view['fields'].values()) == {'-'}
    assert view['level'] is None and not view['low'] and not view['critical']
    text = app.to_json(view)
    assert 'NaN' not in text and json.loads(text)['values'] == {'voltage': None, 'current': None,
                                                                'temperature': None}
    assert app.to_json({'a': [NAN, 1.0, {'b': math.inf}]}) == '{"a":[null,1.0,{"b":null}]}'


def test_field_text():
    dashboard = DashboardModel(history_s=600)
    dashboard.on_battery(TOPIC, battery(), 0.0)
    fields = dashboard.snapshot(0.1)[0]['fields']
    assert fields['percentage'] == '63.2 %'
    assert fields['voltage'] == '11.50 V' and fields['current'] == '-1.50 A' and fields['temperature'] == '25.0 °C'
    assert fields['status'] == 'Discharging' and fields['time_remaining'] == '1 h 16 min'   # 1.9 Ah at 1.5 A
    assert texts.duration_text(40) == '40 s' and texts.duration_text(420) == '7 min'
    assert texts.duration_text(7500) == '2 h 05 min'


def test_status_names():
    assert [model.status_name(s) for s in (0, 1, 2, 3, 4)] == ['-', 'Charging', 'Discharging', 'Not charging',
                                                                 'Full']
    assert model.status_name(3, percentage=0.0) == 'Empty'
    assert model.status_name(3, 'Empty', 0.02) == 'Empty'                # the simulator knows
    assert model.status_name(3, 'Not Charging', 0.5) == 'Not charging'


def test_time_remaining_to_empty_or_full_at_the_present_current():
    assert model.time_remaining_s({'charge': 1.5, 'capacity': 3.0, 'current': -1.5}, 'Discharging') == 3600.0
    assert model.time_remaining_s({'charge': 1.5, 'capacity': 3.0, 'current': 3.0}, 'Charging') == 1800.0
    assert model.time_remaining_s({'charge': 1.5, 'capacity': 3.0, 'current': 0.0}, 'Discharging') is None
    assert model.time_remaining_s({'charge': NAN, 'capacity': 3.0, 'current': -1.0}, 'Discharging') is None
    assert model.time_remaining_s({'charge': 3.0, 'capacity': 3.0, 'current': 0.0}, 'Full') is None
    # a driver that sends 0 for "not measured" charge and capacity: unknown, not "0 s"
    assert model.time_remaining_s({'charge': 0.0, 'capacity': 0.0, 'current': -1.0}, 'Discharging') is None
    dashboard = DashboardModel(history_s=600)
    dashboard.on_battery(TOPIC, battery(), 0.0)
    dashboard.on_sim_state(TOPIC, {'charging_state': 'Discharging', 'time_remaining_s': 600.0}, 0.0)
    assert dashboard.snapshot(0.1)[0]['fields']['time_remaining'] == '10 min'   # the simulator's own figure
    dashboard.on_sim_state(TOPIC, {'charging_state': 'Full', 'time_remaining_s': NAN}, 0.0)
    assert dashboard.snapshot(0.1)[0]['fields']['time_remaining'] == '-'


def test_low_and_critical_from_the_topics_where_they_exist_else_20_and_5_percent():
    assert model.level_flags(0.25, None, None) == (False, False)
    assert model.level_flags(0.15, None, None) == (True, False)
    assert model.level_flags(0.03, None, None) == (True, True)
    assert model.level_flags(NAN, None, None) == (False, False)
    assert model.level_flags(0.22, True, False) == (True, False)     # hysteresis: the topic still says low
    assert model.level_flags(0.15, False, False) == (False, False)   # a publisher with other thresholds
    dashboard = DashboardModel(history_s=600)
    dashboard.on_battery(TOPIC, battery(percentage=0.5), 0.0)
    dashboard.on_level_topic(TOPIC, 'critical', True, 0.0)
    view = dashboard.snapshot(0.1)[0]
    assert view['critical'] and not view['low']


def test_history_is_trimmed_to_history_s_and_thinned_to_a_bounded_number_of_points():
    dashboard = DashboardModel(history_s=100)
    for k in range(3000):   # 20 Hz for 150 s
        dashboard.on_battery(TOPIC, battery(percentage=0.5 + k * 1e-5), k * 0.05)
    dashboard.tick(150.0)
    history = dashboard.history(TOPIC, 150.0)
    assert history['t'][0] >= 50.0 and history['t'][-1] >= 149.0
    assert len(history['t']) <= model.HISTORY_POINTS + 1
    assert len(history['percentage']) == len(history['voltage']) == len(history['t'])
    assert history['percentage'][-1] == pytest.approx(100.0 * (0.5 + 2999e-5), abs=0.1)
    assert dashboard.history('/nobody', 150.0) is None


def test_a_fleet_host_names_the_host_and_gives_a_first_value():
    dashboard = DashboardModel(history_s=600)
    dashboard.on_fleet(TOPIC, '/battery_fleet', battery(percentage=0.4), 0.0)
    view = dashboard.snapshot(0.0)[0]
    assert view['host'] == '/battery_fleet' and view['fields']['percentage'] == '40.0 %'
    dashboard.on_battery(TOPIC, battery(percentage=0.41), 0.5)
    dashboard.on_fleet(TOPIC, '/battery_fleet', battery(percentage=0.2), 1.0)   # its own topic rules
    assert dashboard.snapshot(1.0)[0]['fields']['percentage'] == '41.0 %'


def fleet_entries(names, level, stamp):
    return [(name, dict(battery(percentage=level), stamp=stamp)) for name in names]


def test_fleet_hosts_on_one_topic_are_merged_by_name_and_keep_their_robots_fresh():
    """Every host publishes its own robots on /battery_fleet/states: host 1's A, B and host 2's C, D
    alternate on the one topic; none of the four leaves or goes stale, each names its own host."""
    dashboard = DashboardModel(history_s=60)
    for k in range(20):   # 1 Hz from each host, 10 s
        t = 0.5 * k
        if k % 2 == 0:
            dashboard.on_fleet_message('/', '/battery_fleet', fleet_entries(['A', 'B'], 0.5, 1000.0 + t), t)
        else:
            dashboard.on_fleet_message('/', '/battery_fleet_1', fleet_entries(['C', 'D'], 0.3, 1000.0 + t), t)
        dashboard.tick(t)
    views = {view['topic']: view for view in dashboard.snapshot(10.0)}
    assert sorted(views) == ['/A/battery_status', '/B/battery_status', '/C/battery_status', '/D/battery_status']
    assert not any(view['stale'] for view in views.values()), [v['topic'] for v in views.values() if v['stale']]
    assert [views['/%s/battery_status' % name]['host'] for name in 'ABCD'] == [
        '/battery_fleet', '/battery_fleet', '/battery_fleet_1', '/battery_fleet_1']
    assert views['/C/battery_status']['fields']['percentage'] == '30.0 %'
    # values are made only when they count (a host of 1000 robots whose own topics speak costs no conversion)
    dashboard.on_battery('/A/battery_status', dict(battery(percentage=0.52), stamp=2000.0), 10.1)
    made = []
    dashboard.on_fleet('/A/battery_status', '/battery_fleet', lambda: made.append(1) or battery(), 10.2)
    assert made == [] and dashboard.snapshot(10.2)[0]['fields']['percentage'] == '52.0 %'   # its own topic rules


def test_a_fleet_host_repeating_a_silent_robots_last_message_does_not_keep_it_fresh():
    """A host lists each robot's latest BatteryState; when the robot's own topic goes quiet (a sensor
    dropout) the host repeats the same message: it goes stale, leaves after history_s, and a repeat of
    that same message does not bring it back; a new one does."""
    dashboard = DashboardModel(history_s=20)
    topic = '/A/battery_status'
    for k in range(5):
        dashboard.on_battery(topic, dict(battery(), stamp=100.0 + k), float(k))
        dashboard.on_fleet_message('/', '/battery_fleet', fleet_entries(['A'], 0.6, 100.0 + k), k + 0.5)
    for k in range(5, 40):   # the robot's own topic is silent: the host repeats its last message
        dashboard.on_fleet_message('/', '/battery_fleet', fleet_entries(['A'], 0.6, 104.0), float(k))
        changed, removed = dashboard.tick(float(k))
        if k == 8:
            assert dashboard.records[topic].stale(8.0)
    assert topic not in dashboard.records and dashboard.snapshot(40.0) == []
    dashboard.on_fleet_message('/', '/battery_fleet', fleet_entries(['A'], 0.6, 140.0), 41.0)   # a new one
    assert [(view['topic'], view['stale']) for view in dashboard.snapshot(41.0)] == [(topic, False)]


def test_snapshot_and_changes_are_in_natural_order_and_each_view_carries_its_order_key():
    """robot2 before robot10 (issue 40 item 5: the plain order put robot10 first); the page places its cards
    by each view's 'order', whose plain string order is the natural one."""
    dashboard = DashboardModel(history_s=600)
    topics = ['/robot10/battery_status', '/robot2/battery_status', '/alpha/battery_status', '/robot1/battery_status',
              '/robot02b/battery_status', '/robot100/battery_status', '/robot9/battery_status']
    for topic in topics:
        dashboard.on_battery(topic, battery(), 0.0)
    natural = ['/alpha/battery_status', '/robot1/battery_status', '/robot2/battery_status',
               '/robot02b/battery_status', '/robot9/battery_status', '/robot10/battery_status',
               '/robot100/battery_status']
    views = dashboard.snapshot(0.0)
    assert [view['topic'] for view in views] == natural
    assert sorted(views, key=lambda view: view['order']) == views, 'the page\'s plain order of the keys differs'
    changed, _ = dashboard.tick(0.5)
    assert [view['topic'] for view in changed] == natural


def test_natural_key():
    assert texts.natural_key('/robot2/x') < texts.natural_key('/robot10/x') < texts.natural_key('/robot10a/x')
    assert texts.natural_key('/a/battery_status') < texts.natural_key('/b/battery_status')
    assert texts.natural_key('/robot007/x') < texts.natural_key('/robot8/x')
    assert sorted(['robot%d' % k for k in range(1000)], key=texts.natural_key) == ['robot%d' % k for k in range(1000)]


# -- the web app's checks -----------------------------------------------------------

def test_only_the_dashboards_own_host_and_origin_are_allowed():
    own = app.own_addresses('127.0.0.1', 8090)
    assert {'127.0.0.1:8090', 'localhost:8090', '[::1]:8090'} <= own
    assert app.request_allowed('127.0.0.1:8090', None, own)
    assert app.request_allowed('LOCALHOST:8090', 'http://localhost:8090', own)
    assert not app.request_allowed('evil.example:8090', None, own)          # DNS rebinding
    assert not app.request_allowed('127.0.0.1:8091', None, own)
    assert not app.request_allowed('127.0.0.1', None, own)
    assert not app.request_allowed(None, None, own)
    assert not app.request_allowed('127.0.0.1:8090', 'http://evil.example', own)   # another site's page
    assert not app.request_allowed('127.0.0.1:8090', 'null', own)
    assert not app.request_allowed('127.0.0.1:8090', 'https://127.0.0.1:8090', own)
    assert 'robot.lan:8090' in app.own_addresses('robot.lan', 8090)
    assert 'evil.example:8090' not in app.own_addresses('0.0.0.0', 8090)


def test_control_requests_are_checked_before_any_call():
    action, arguments = app.control_request({'action': 'set_state', 'percentage': '15', 'temperature_c': ''})
    assert action == 'set_state' and arguments['percentage'] == 15.0 and math.isnan(arguments['temperature_c'])
    assert app.control_request({'action': 'set_charging', 'charging': True}) == ('set_charging', {'charging': True})
    assert app.control_request({'action': 'inject_fault', 'fault': 'overheat', 'active': False}) == (
        'inject_fault', {'fault': 'overheat', 'active': False})
    for bad in ({'action': 'set_state', 'percentage': 101}, {'action': 'set_state', 'percentage': -1},
                {'action': 'set_state', 'percentage': 'NaN'}, {'action': 'set_state', 'percentage': 'junk'},
                {'action': 'set_state', 'percentage': True}, {'action': 'set_state'},
                {'action': 'set_state', 'temperature_c': 500}, {'action': 'set_state', 'state_of_health': 0},
                {'action': 'set_state', 'state_of_health': 1.5},
                {'action': 'set_charging', 'charging': 'yes'}, {'action': 'inject_fault', 'fault': 'fire',
                                                                 'active': True},
                {'action': 'inject_fault', 'fault': 'overheat', 'active': 1},
                {'action': 'reset'}, {'action': 'set_load', 'name': 'x', 'power_w': 1}, [], None, 'set_state'):
        with pytest.raises(ValueError):
            app.control_request(bad)


class TestWebApp(tornado_testing.AsyncHTTPTestCase):
    """The app on a real socket (no ROS): pages, 403s, controls off by default."""

    def get_app(self):
        self.calls = []
        self.hub = app.Hub(600.0, allow_control=False, call_service=self._call)
        self.hub.model.add(TOPIC, 0.0, has_controls=True)
        self.hub.model.on_battery(TOPIC, battery(), 1.0)
        return app.make_app(self.hub, '127.0.0.1', self.get_http_port())

    def get_httpserver_options(self):
        return app.server_options()   # as the node listens

    def _call(self, *arguments):
        self.calls.append(arguments)
        if arguments[2].get('percentage') == 97:   # a value the service refuses (the dashboard let it through)
            return app.SERVICE_REFUSED, 'percentage = 97 is refused by the service'
        if arguments[2].get('percentage') == 99:
            return app.SERVICE_UNREACHABLE, '/robot3/battery_simulator/set_state: timeout'
        if arguments[2].get('percentage') == 98:   # a service that hangs
            time.sleep(1.0)
        return app.SERVICE_OK, 'done'

    def host(self):
        return '127.0.0.1:%d' % self.get_http_port()

    def test_pages_and_chart_js_are_served_to_the_own_host(self):
        for path in ('/', '/battery?topic=%2Frobot3%2Fbattery_status', '/static/dashboard.js',
                     '/static/dashboard.css'):
            response = self.fetch(path, headers={'Host': self.host()})
            assert response.code == 200, path
            assert response.headers['X-Frame-Options'] == 'DENY'
        assert b'data-page="overview"' in self.fetch('/', headers={'Host': self.host()}).body
        chart = self.fetch('/javascript/chart.js/chart.min.js', headers={'Host': self.host()})
        assert chart.code == 200 and b'Chart.js' in chart.body[:200]
        batteries = json.loads(self.fetch('/api/batteries', headers={'Host': self.host()}).body)
        assert [b['topic'] for b in batteries['batteries']] == [TOPIC] and batteries['allow_control'] is False

    def test_a_foreign_host_or_origin_gets_403(self):
        for headers in ({'Host': 'evil.example:%d' % self.get_http_port()},
                        {'Host': self.host(), 'Origin': 'http://evil.example'}):
            for path in ('/', '/battery', '/static/dashboard.js', '/api/batteries', '/live',
                         '/javascript/chart.js/chart.min.js', '/no/such/page'):
                assert self.fetch(path, headers=headers).code == 403, (path, headers)
        assert self.fetch('/no/such/page', headers={'Host': self.host()}).code == 404

    def test_a_read_only_page_has_no_control_element_at_all(self):
        page = self.fetch('/battery?topic=%2Frobot3%2Fbattery_status', headers={'Host': self.host()}).body
        assert b'<button' not in page and b'<input' not in page and b'data-chart="percentage"' in page
        self.hub.allow_control = True
        page = self.fetch('/battery?topic=%2Frobot3%2Fbattery_status', headers={'Host': self.host()}).body
        assert b'<button' in page and b'name="percentage"' in page

    def test_controls_are_off_unless_allowed(self):
        response = self.fetch('/api/control', method='POST', headers={'Host': self.host(),
                                                                      'Content-Type': 'application/json'},
                              body=json.dumps({'topic': TOPIC, 'action': 'set_charging', 'charging': True}))
        assert response.code == 403 and self.calls == []

    def test_with_controls_on_only_checked_requests_reach_the_service(self):
        self.hub.allow_control = True
        headers = {'Host': self.host(), 'Content-Type': 'application/json', 'Origin': 'http://' + self.host()}

        def post(body, extra=None):
            return self.fetch('/api/control', method='POST', headers=dict(headers, **(extra or {})),
                              body=json.dumps(body))
        assert post({'topic': TOPIC, 'action': 'set_state', 'percentage': 300}).code == 400
        for topic in ([TOPIC], {'a': 1}, None, 3):   # not a name: refused, no 500
            assert post({'topic': topic, 'action': 'set_charging', 'charging': True}).code == 400, topic
        assert post({'topic': '/nobody/battery_status', 'action': 'set_charging', 'charging': True}).code == 404
        assert post({'topic': TOPIC, 'action': 'set_charging', 'charging': True},
                    {'Origin': 'http://evil.example'}).code == 403
        assert post({'topic': TOPIC, 'action': 'set_charging', 'charging': True},
                    {'Content-Type': 'text/plain'}).code == 415
        assert self.calls == []
        assert post({'topic': TOPIC, 'action': 'set_state', 'percentage': 15}).code == 200
        assert self.calls[0][:2] == (TOPIC, 'set_state') and self.calls[0][2]['percentage'] == 15.0
        refused = post({'topic': TOPIC, 'action': 'set_state', 'percentage': 97})
        assert refused.code == 422, 'a value the service refuses is the user\'s error (4xx), not a 502'
        assert 'percentage = 97 is refused' in json.loads(refused.body)['message']
        calls = len(self.calls)
        below = post({'topic': TOPIC, 'action': 'set_state', 'state_of_health': 0.001})
        assert below.code == 400 and len(self.calls) == calls, 'below the simulator\'s least health: no call'
        assert '[0.01, 1]' in json.loads(below.body)['message'], json.loads(below.body)['message']
        assert post({'topic': TOPIC, 'action': 'set_state', 'percentage': 99}).code == 502, 'a service gone: 502'
        self.hub.call_timeout_s = 0.2
        hung = post({'topic': TOPIC, 'action': 'set_state', 'percentage': 98})
        assert hung.code == 504 and 'no answer' in json.loads(hung.body)['message'], 'a service that hangs: 504'

    def test_a_huge_query_string_gets_414(self):
        response = self.fetch('/battery?topic=' + 'x' * 100000, headers={'Host': self.host()})
        assert response.code == 414, response.code

    def test_a_probe_of_refused_requests_writes_one_line_then_a_count_every_10_s(self):
        """81 requests with a foreign Host, 3 unknown paths, a 100 kB URI: one line at once, then one line
        with their count at the end of the 10 s (the node writes tornado's own warnings to the ROS log
        too: none of those either)."""
        lines, later = [], []
        self._app.settings['log_function'] = app.RequestLog(
            lines.append, call_later=lambda delay_s, function: later.append((delay_s, function)))
        tornado_lines = []
        capture = logging.Handler(logging.WARNING)
        capture.emit = tornado_lines.append
        for name in app.TORNADO_LOGGERS:
            logging.getLogger(name).addHandler(capture)
        try:
            for _ in range(81):
                assert self.fetch('/', headers={'Host': 'evil.example:1'}).code == 403
            for k in range(3):
                assert self.fetch('/no/page%d' % k, headers={'Host': self.host()}).code == 404
            assert self.fetch('/?q=' + 'x' * 100000, headers={'Host': self.host()}).code == 414
            assert self.fetch('/', headers={'Host': self.host()}).code == 200
        finally:
            for name in app.TORNADO_LOGGERS:
                logging.getLogger(name).removeHandler(capture)
        assert [record.getMessage() for record in tornado_lines] == []
        assert lines == ["request refused: 403 GET / (Host 'evil.example:1', Origin None)"], lines
        assert [delay for delay, _ in later] == [10.0]
        later.pop()[1]()                                  # 10 s on: the count
        assert len(lines) == 2 and lines[1].startswith(
            '84 more request(s) refused or failed in the last 10 s (80 x 403, 3 x 404, 1 x 414); the last: 414 GET'), \
            lines
        assert len(later) == 1
        later.pop()[1]()                                  # a quiet period: nothing more to say
        assert len(lines) == 2 and later == []
        assert self.fetch('/no/page', headers={'Host': self.host()}).code == 404   # said at once again
        assert lines[2] == 'request refused: 404 GET /no/page' and len(later) == 1


    def test_bad_paths_get_4xx_and_a_flood_of_them_one_line_then_one_count(self):
        """Issue 40 item 5: 200 path traversals gave 200 WARN lines (tornado's own, one per 403), and 100
        /static/%00 gave 100 tracebacks and 500 (tornado >= 6.5; the ROS 2 test goes through that one)."""
        lines, later = [], []
        self._app.settings['log_function'] = app.RequestLog(
            lines.append, call_later=lambda delay_s, function: later.append((delay_s, function)))
        tornado_lines = []
        capture = logging.Handler(logging.DEBUG)
        capture.emit = tornado_lines.append
        for name in app.TORNADO_LOGGERS:
            logging.getLogger(name).addHandler(capture)
        bad = ['/static/../../../../etc/passwd', '/static/..%2f..%2f..%2fetc%2fpasswd', '/static/%2e%2e/%2e%2e/x',
               '/javascript/chart.js/..%2f..%2fetc%2fpasswd', '/static//etc/passwd', '/static/..', '/static/',
               '/static/%00', '/static/a%00b.js', '/static/dashboard.js%00', '/static/%0a', '/static/%ff',
               '/api/history?topic=%ff', '/api/history?topic=%00', '/%00', '/static/nothing.js']
        try:
            codes = {}
            for round_ in range(13):
                for path in bad:
                    codes[path] = self.fetch(path, headers={'Host': self.host()}).code
        finally:
            for name in app.TORNADO_LOGGERS:
                logging.getLogger(name).removeHandler(capture)
        assert all(code in (400, 403, 404) for code in codes.values()), codes
        assert codes['/static/%00'] == 400 and codes['/static/../../../../etc/passwd'] == 403, codes
        assert [r.getMessage() for r in tornado_lines if r.levelno >= logging.WARNING] == [], \
            'tornado said something of its own'
        assert len(lines) == 1 and lines[0].startswith('request refused: 403 GET /static/../../../../etc/passwd'), lines
        later.pop()[1]()
        assert len(lines) == 2 and lines[1].startswith('%d more request(s) refused or failed in the last 10 s'
                                                       % (13 * len(bad) - 1)), lines

    def test_a_failure_that_is_not_an_http_error_is_named_on_the_one_line_without_a_traceback(self):
        lines, later = [], []
        self._app.settings['log_function'] = app.RequestLog(
            lines.append, call_later=lambda delay_s, function: later.append((delay_s, function)))
        tornado_lines = []
        capture = logging.Handler(logging.WARNING)
        capture.emit = tornado_lines.append
        for name in app.TORNADO_LOGGERS:
            logging.getLogger(name).addHandler(capture)
        original = self.hub.model.history
        self.hub.model.history = lambda topic, now: 1 / 0
        try:
            for _ in range(5):
                assert self.fetch('/api/history?topic=x', headers={'Host': self.host()}).code == 500
        finally:
            self.hub.model.history = original
            for name in app.TORNADO_LOGGERS:
                logging.getLogger(name).removeHandler(capture)
        assert tornado_lines == [] and len(lines) == 1, (lines, tornado_lines)
        assert lines[0] == 'request failed: 500 GET /api/history?topic=x (ZeroDivisionError: division by zero)', lines


def test_the_ready_line_gives_an_address_a_browser_opens():
    from battery_simulator.web.dashboard_rules import page_url, ready_line
    assert page_url('::', 8090) == 'http://[::]:8090/'
    assert page_url('::1', 80) == 'http://[::1]:80/'
    assert page_url('[::1]', 8090) == 'http://[::1]:8090/'
    assert page_url('0.0.0.0', 8090) == 'http://0.0.0.0:8090/'
    assert ready_line({'host': '::', 'port': 8091, 'allow_control': False}) == \
        'battery_dashboard: http://[::]:8091/ (read-only)'


def test_the_node_warns_at_start_up_when_the_chart_library_is_missing(tmp_path):
    """(The page's own note: test_dashboard_without_charts.py.) A directory without chart.min.js is missing
    too (the page loads that file)."""
    (tmp_path / 'Chart.js').write_text('')
    problem = app.chart_library_problem(str(tmp_path))
    assert 'chart library is missing' in problem and 'libjs-chart.js' in problem and str(tmp_path) in problem
    assert 'missing' in app.chart_library_problem(str(tmp_path / 'nowhere'))
    (tmp_path / 'chart.min.js').write_text('/* Chart.js */')
    assert app.chart_library_problem(str(tmp_path)) is None


def test_a_stalled_page_is_closed_rather_than_buffered_for():
    import concurrent.futures
    import types
    socket = app.LiveSocket.__new__(app.LiveSocket)
    hub = app.Hub(600.0, False)
    socket._unsent, closed, pending = 0, [], []
    socket.application = types.SimpleNamespace(settings={'hub': hub})
    hub.pages.add(socket)
    socket.write_message = lambda message: pending.append(concurrent.futures.Future()) or pending[-1]
    socket.close = lambda code=None, reason=None: closed.append(code)
    for _ in range(app.MAX_UNSENT_PUSHES):
        socket.send('{}')
    assert not closed and socket in hub.pages
    pending[0].set_result(None)               # the page took one: room for one more
    socket.send('{}')
    assert not closed
    socket.send('{}')                         # a whole minute of pushes unsent: closed, no longer pushed to
    assert closed == [1013] and socket not in hub.pages


def test_numbers_no_one_can_read_are_shown_short_and_marked():
    assert texts.number_text(3.4e38, 2, 'V', 'voltage') == '3.4e+38 V (out of range)'
    assert texts.percentage_text(-1e9) == '-1e+11 % (out of range)'
    assert texts.percentage_text(0.632) == '63.2 %' and texts.number_text(12.31, 2, 'V') == '12.31 V'
    assert texts.number_text(0.0, 2, 'V', 'voltage') == '0.00 V (out of range)'   # no pack reads 0 V
    assert texts.number_text(-1.0, 2, 'V', 'voltage') == '-1.00 V (out of range)'
    assert texts.number_text(2500.0, 2, 'A', 'current') == '2500.00 A (out of range)'
    assert texts.number_text(math.inf, 2, 'V', 'voltage') == '-'
    record = model.DashboardBattery('/r/battery_status', 0.0)
    record.on_battery(battery(percentage=-1e9, voltage=3.4e38), 1.0, 1.0)
    view = record.view(1.0)
    assert view['out_of_range'] == ['percentage', 'voltage'], view['out_of_range']
    assert max(len(text) for text in view['fields'].values()) < 30, view['fields']


def test_a_time_remaining_from_absurd_values_is_unknown_and_every_shown_text_is_short():
    """A charge of 3.4e38 Ah over a sane current made a 40-digit time remaining ('2266...6588 h 48 min');
    the simulator's cycle count and health are the server's text too, short and marked."""
    record = model.DashboardBattery('/r/battery_status', 0.0)
    record.on_battery(battery(charge=3.4e38, current=-1.5), 1.0, 1.0)
    record.sim = {'cycle_count': 3.4e38, 'state_of_health': -1e9}
    view = record.view(1.0)
    assert view['fields']['time_remaining'] == '-', view['fields']
    assert view['fields']['charge'] == '3.4e+38 Ah (out of range)'
    assert view['fields']['cycle_count'] == '3.4e+38 (out of range)'
    assert view['fields']['state_of_health'] == '-1e+11 % (out of range)'
    assert view['out_of_range'] == ['charge', 'cycle_count', 'state_of_health'], view['out_of_range']
    assert max(len(text) for text in view['fields'].values()) < 30, view['fields']
    assert texts.duration_text(1e4 * 3600.0) == '> 9999 h' and texts.duration_text(7500) == '2 h 05 min'
    record.sim = {'cycle_count': 12.5, 'state_of_health': 0.93}
    fields = record.view(1.0)['fields']
    assert (fields['cycle_count'], fields['state_of_health']) == ('12.50', '93.0 %')


def test_a_silent_but_advertised_topic_stays_away_once_dropped():
    dashboard = model.DashboardModel(history_s=60.0)
    dashboard.add(TOPIC, 0.0)
    dashboard.on_battery(TOPIC, battery(), 1.0)
    dashboard.tick(100.0)                           # silent for longer than history_s: dropped
    assert TOPIC not in dashboard.records
    dashboard.add(TOPIC, 102.0)                     # the next scan finds it still advertised
    changed, _ = dashboard.tick(103.0)
    assert TOPIC not in dashboard.records and not changed, 'it came back as fresh without a message'
    dashboard.on_battery(TOPIC, battery(), 104.0)   # a message brings it back
    assert TOPIC in dashboard.records and not dashboard.records[TOPIC].stale(104.5)


def test_the_page_takes_its_texts_and_limits_from_the_core():
    """The health texts are the diagnostics' (core/status_codes.py), set_state's limits the simulator's
    (core/battery_model.py), the low / critical defaults battery_state_pub's (core/node_settings.py)."""
    from battery_simulator.core import status_codes
    from battery_simulator.core.battery_model import MIN_STATE_OF_HEALTH, SET_STATE_TEMPERATURE_C
    from battery_simulator.core.node_settings import PUBLISHER_SETTINGS
    dashboard = DashboardModel(history_s=600)
    for code, text in status_codes.HEALTH_TEXT.items():
        dashboard.on_battery(TOPIC, battery(health=code), 0.0)
        shown = dashboard.snapshot(0.1)[0]['fields']['health']
        assert shown == ('-' if code == status_codes.SupplyHealth.UNKNOWN else text), (code, shown)
    assert app.SET_STATE_RANGES['state_of_health'] == (MIN_STATE_OF_HEALTH, 1.0)
    assert app.SET_STATE_RANGES['temperature_c'] == SET_STATE_TEMPERATURE_C
    with pytest.raises(ValueError, match=r'\[0\.01, 1\]'):
        app.control_request({'action': 'set_state', 'state_of_health': MIN_STATE_OF_HEALTH / 2})
    defaults = {setting.name: setting.default for setting in PUBLISHER_SETTINGS}
    assert (model.LOW_FRACTION, model.CRITICAL_FRACTION) == (defaults['low_percentage'],
                                                             defaults['critical_percentage'])
