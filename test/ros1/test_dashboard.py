#!/usr/bin/python3
"""rostest: the live dashboard (test/ros1/dashboard.test) read the way a person reads it, in headless
Chromium: a fleet of five, each level as battery_status says, a set_state within 1 s, low and
critical marked, the detail page's charts (with controls, and read-only without any), the
controls' checks, a battery with NaN fields that goes stale and then away, 403 for a foreign
Host, a port in use stopping a second dashboard, and a second fleet host on the one
/battery_fleet/states topic merged with the first by robot name."""
import http.client
import json
import math
import os
import shutil
import subprocess
import tempfile
import threading
import time
import unittest

import rospy
import rostest
from selenium import webdriver
from selenium.webdriver.chrome.service import Service
from selenium.webdriver.common.by import By
from selenium.webdriver.support.ui import WebDriverWait
from sensor_msgs.msg import BatteryState
from std_msgs.msg import Header

from battery_simulator.msg import BatteryFleetState
from battery_simulator.srv import SetState
from battery_simulator.web.dashboard_texts import natural_key
from rostest_helpers import Recorder, SetStateProxy, node_command, stop_process, wait_for

ROBOTS = ['robot%d' % k for k in range(5)]
NAN_TOPIC = '/zz_nan/battery_status'   # sorts after the robots
HISTORY_S = 10.0                       # ~history_s in test/ros1/dashboard.test
SECOND_HOST_ROBOTS = ['zz_fleet_a', 'zz_fleet_b']   # a second fleet host's robots (sort after the robots)


WATCH_LEVEL = '''
const [selector, level] = arguments;
const field = document.querySelector(selector + ' [data-field="percentage"]');
window.levelShownAt = null;
new MutationObserver((changes, observer) => {
  if (Math.abs(parseFloat(field.textContent) - level) < 0.15) {
    window.levelShownAt = Date.now();
    observer.disconnect();
  }
}).observe(field, {childList: true, characterData: true, subtree: true});
'''


class SecondHost:
    """This test node plays a second fleet host: its robots (no battery_status of their own) on the
    one topic /battery_fleet/states at 2 Hz, each message new (its own stamp), for the whole test."""

    def __init__(self):
        self.publisher = rospy.Publisher('/battery_fleet/states', BatteryFleetState, queue_size=1)
        self.started = time.monotonic()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._publish, daemon=True)
        self._thread.start()

    def _publish(self):
        while not self._stop.is_set():
            states = [BatteryState(header=Header(stamp=rospy.Time.now()), percentage=0.5 + 0.1 * k, voltage=11.0,
                                   current=-1.0, temperature=25.0, power_supply_status=2, present=True)
                      for k in range(len(SECOND_HOST_ROBOTS))]
            self.publisher.publish(BatteryFleetState(names=SECOND_HOST_ROBOTS, states=states))
            self._stop.wait(0.5)

    def stop(self):
        self._stop.set()
        self._thread.join(5.0)
        self.publisher.unregister()


def topic_of(robot):
    return '/%s/battery_status' % robot


def card_selector(topic):
    return '[data-battery="%s"]' % topic


class TestDashboard(unittest.TestCase):

    @classmethod
    def setUpClass(cls):
        rospy.init_node('test_dashboard')
        cls.port = int(rospy.get_param('~port'))
        cls.url = 'http://127.0.0.1:%d' % cls.port
        cls.status = {robot: Recorder(topic_of(robot)) for robot in ROBOTS}
        wait_for(lambda: all(r.count() > 0 for r in cls.status.values()), 60.0, 'battery_status of every robot')
        wait_for(cls.dashboard_answers, 60.0, 'the dashboard at %s' % cls.url)
        cls.second_host = SecondHost()

    @classmethod
    def tearDownClass(cls):
        cls.second_host.stop()

    @classmethod
    def dashboard_answers(cls):
        try:
            return cls.request('/api/batteries')[0] == 200
        except OSError:
            return False

    @classmethod
    def request(cls, path, host=None, method='GET'):
        connection = http.client.HTTPConnection('127.0.0.1', cls.port, timeout=5.0)
        try:
            connection.putrequest(method, path, skip_host=True)
            connection.putheader('Host', host or '127.0.0.1:%d' % cls.port)
            connection.endheaders()
            response = connection.getresponse()
            return response.status, response.read()
        finally:
            connection.close()

    def setUp(self):
        options = webdriver.ChromeOptions()
        for argument in ('--headless=new', '--no-sandbox', '--disable-gpu', '--window-size=1280,900'):
            options.add_argument(argument)
        options.set_capability('goog:loggingPrefs', {'browser': 'ALL'})
        # Chromium's own temporary directories in one of ours, removed after (it leaves one in TMPDIR at every quit)
        self.temporary = tempfile.mkdtemp(prefix='test_dashboard_')
        self.addCleanup(shutil.rmtree, self.temporary, True)
        self.driver = webdriver.Chrome(options=options, service=Service('/usr/bin/chromedriver',
                                                                        env=dict(os.environ, TMPDIR=self.temporary)))
        self.driver.get(self.url + '/')
        self.wait(30.0, lambda d: len(self.cards()) >= len(ROBOTS), 'a card per robot')

    def tearDown(self):
        try:
            errors = [entry for entry in self.driver.get_log('browser') if entry['level'] == 'SEVERE']
            self.assertEqual(errors, [], 'the page logged errors')
        finally:
            self.driver.quit()

    # -- helpers
    def wait(self, timeout_s, condition, what):
        return WebDriverWait(self.driver, timeout_s, poll_frequency=0.05).until(condition, message=what)

    def cards(self):
        return self.driver.find_elements(By.CSS_SELECTOR, '[data-battery]')

    def card(self, topic):
        return self.driver.find_element(By.CSS_SELECTOR, card_selector(topic))

    def field(self, topic, name):
        return self.card(topic).find_element(By.CSS_SELECTOR, '[data-field="%s"]' % name).text

    def classes(self, topic):
        return self.card(topic).get_attribute('class').split()

    def shown_level(self, topic):
        return float(self.field(topic, 'percentage').split()[0])

    def set_state(self, robot, percentage):
        set_state = SetStateProxy('/%s/battery_simulator/set_state' % robot)
        set_state.wait_for_service(10.0)
        self.assertTrue(set_state(percentage, math.nan, math.nan).success)

    # -- the tests
    def test_1_one_element_per_battery_sorted_with_the_level_of_battery_status(self):
        topics = [card.get_attribute('data-battery') for card in self.cards()]
        self.assertEqual(topics[:len(ROBOTS)], [topic_of(robot) for robot in ROBOTS])
        self.assertEqual(topics, sorted(topics, key=natural_key), 'in the natural order of their names')
        for robot in ROBOTS:
            # level, voltage and current of one and the same message (a new one may land between reads)
            def shown():
                return tuple(self.field(topic_of(robot), name) for name in ('percentage', 'voltage', 'current'))

            def expected():
                latest = self.status[robot].latest()
                return ('%.1f %%' % (100.0 * latest.percentage), '%.2f V' % latest.voltage,
                        '%.2f A' % latest.current)
            self.wait(3.0, lambda d: shown() == expected(),
                      '%s shows the level, voltage and current of its latest battery_status' % robot)
            self.assertEqual(self.field(topic_of(robot), 'status'), 'Discharging')
            self.assertTrue(self.field(topic_of(robot), 'temperature').endswith('°C'))
            self.assertRegex(self.field(topic_of(robot), 'time_remaining'), r'^\d+ (h \d\d )?min$')
            self.assertNotIn('stale', self.classes(topic_of(robot)))

    def test_2_a_set_state_shows_within_1_s(self):
        for level in (55.5, 61.0):
            # the page notes (wall clock, ms) when the text first shows the level: no polling in the figure
            self.driver.execute_script(WATCH_LEVEL, card_selector(topic_of('robot2')), level)
            self.set_state('robot2', level)   # replies once battery_status has sent it
            sent = time.time()
            shown_ms = self.wait(5.0, lambda d: d.execute_script('return window.levelShownAt'),
                                 'robot2 at %g %% on the page' % level)
            rospy.loginfo('set_state %g %%: on the page %.0f ms after the service replied', level,
                          shown_ms - 1000.0 * sent)
            self.assertLess(shown_ms / 1000.0 - sent, 1.0, 'robot2 at %g %% within 1 s of battery_status' % level)

    def test_3_low_and_critical_are_marked(self):
        topic = topic_of('robot3')
        self.set_state('robot3', 15.0)
        self.wait(2.0, lambda d: 'low' in self.classes(topic) and 'critical' not in self.classes(topic), 'robot3 low')
        self.set_state('robot3', 3.0)
        self.wait(2.0, lambda d: 'critical' in self.classes(topic), 'robot3 critical')
        self.assertIn('CRITICAL', self.card(topic).text)
        self.set_state('robot3', 80.0)
        self.wait(2.0, lambda d: not {'low', 'critical'} & set(self.classes(topic)), 'robot3 neither low nor critical')
        for robot in ('robot0', 'robot1'):
            self.assertFalse({'low', 'critical'} & set(self.classes(topic_of(robot))), robot)

    def test_4_a_click_opens_the_battery_with_its_charts(self):
        self.card(topic_of('robot0')).click()
        self.wait(10.0, lambda d: '/battery?topic=' in d.current_url, 'the battery page')
        self.assertIn('topic=%2Frobot0%2Fbattery_status', self.driver.current_url)
        self.wait(5.0, lambda d: self.field(topic_of('robot0'), 'percentage') ==
                  '%.1f %%' % (100.0 * self.status['robot0'].latest().percentage), 'the level on the battery page')
        points = ("return Object.values(window.batteryCharts || {}).map("
                  "c => c.data.datasets[0].data.filter(p => Number.isFinite(p.y)).length)")
        self.wait(10.0, lambda d: len(d.execute_script(points)) == 4 and min(d.execute_script(points)) >= 2,
                  'four charts with at least two points each')
        painted = ("const c = document.querySelector('canvas[data-chart=\"%s\"]');"
                   "const p = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;"
                   "let n = 0; for (let i = 3; i < p.length; i += 4) if (p[i] > 0) n++; return [c.width, n];")
        for chart in ('percentage', 'voltage', 'current', 'temperature'):
            width, painted_pixels = self.driver.execute_script(painted % chart)
            self.assertGreater(width, 100, chart)
            self.assertGreater(painted_pixels, 500, '%s chart drawn' % chart)

    def test_4b_a_read_only_battery_page_draws_its_charts_without_controls_or_errors(self):
        port = self.port + 1   # a second, read-only dashboard (the one under test has controls on)
        read_only = subprocess.Popen(node_command('battery_dashboard.py') + ['__name:=read_only_dashboard',
                                                                            '_port:=%d' % port], start_new_session=True)
        try:
            wait_for(lambda: self.answers_on(port), 30.0, 'the read-only dashboard')
            self.driver.get('http://127.0.0.1:%d/battery?topic=%%2Frobot0%%2Fbattery_status' % port)
            points = ("return Object.values(window.batteryCharts || {}).map("
                      "c => c.data.datasets[0].data.filter(p => Number.isFinite(p.y)).length)")
            self.wait(15.0, lambda d: len(d.execute_script(points)) == 4 and min(d.execute_script(points)) >= 2,
                      'four charts with at least two points each')
            self.assertEqual(self.driver.find_elements(By.CSS_SELECTOR, 'button, input, #controls'), [])
        finally:   # tearDown: no error in the page's console (the page's scripts ran to the end)
            stop_process(read_only)

    @staticmethod
    def answers_on(port):
        connection = http.client.HTTPConnection('127.0.0.1', port, timeout=2.0)
        try:
            connection.request('GET', '/api/batteries', headers={'Host': '127.0.0.1:%d' % port})
            return connection.getresponse().status == 200
        except OSError:
            return False
        finally:
            connection.close()

    def test_5_controls_refuse_out_of_range_values_and_call_set_state(self):
        topic = topic_of('robot4')
        self.driver.get(self.url + '/battery?topic=%2Frobot4%2Fbattery_status')
        self.wait(10.0, lambda d: d.find_element(By.ID, 'controls').is_displayed(), 'the controls')
        level = self.driver.find_element(By.CSS_SELECTOR, '#set-state input[name="percentage"]')
        before = self.status['robot4'].count()
        level.send_keys('300')
        self.driver.find_element(By.CSS_SELECTOR, '#set-state button[type="submit"]').click()
        self.wait(2.0, lambda d: 'out of range' in d.find_element(By.ID, 'control-result').text, 'refused in the page')
        level.clear()
        level.send_keys('42')
        self.driver.find_element(By.CSS_SELECTOR, '#set-state button[type="submit"]').click()
        self.wait(5.0, lambda d: 'state set' in d.find_element(By.ID, 'control-result').text, 'set_state called')
        self.wait(2.0, lambda d: abs(self.shown_level(topic) - 42.0) < 0.15, 'robot4 at 42 % on the page')
        self.assertAlmostEqual(self.status['robot4'].latest().percentage, 0.42, delta=0.002)
        self.assertTrue(all(m.percentage < 0.9 or m.percentage > 0.99 for m in self.status['robot4'].since(before)),
                        'nothing like 300 % was ever set')

    def test_6_a_foreign_host_gets_403(self):
        self.assertEqual(self.request('/', host='evil.example:%d' % self.port)[0], 403)
        self.assertEqual(self.request('/api/batteries', host='attacker.test')[0], 403)
        self.assertEqual(self.request('/')[0], 200)
        self.assertEqual(self.request('/', host='localhost:%d' % self.port)[0], 200)

    def test_7_a_battery_with_nan_fields_shows_dashes_goes_stale_then_away(self):
        publisher = rospy.Publisher(NAN_TOPIC, BatteryState, queue_size=1)
        nan = math.nan
        msg = BatteryState(voltage=nan, temperature=nan, current=nan, charge=nan, capacity=nan,
                           design_capacity=nan, percentage=nan)
        deadline = time.monotonic() + 30.0
        while not self.cards_with(NAN_TOPIC) and time.monotonic() < deadline:
            publisher.publish(msg)
            time.sleep(0.2)   # a 5 Hz publisher, until the page shows it
        self.assertTrue(self.cards_with(NAN_TOPIC), 'the NaN battery on the page')
        for _ in range(10):
            publisher.publish(msg)
            last_sent = time.monotonic()
            time.sleep(0.2)
        for name in ('percentage', 'status', 'voltage', 'current', 'temperature', 'time_remaining'):
            self.assertEqual(self.field(NAN_TOPIC, name), '-', name)
        self.assertNotIn('stale', self.classes(NAN_TOPIC))
        publisher.unregister()
        # staleness counts from the last message, sent before the page's fields were read (each read a browser
        # round trip: on a busy machine they took over half a second)
        self.wait(5.0, lambda d: 'stale' in self.classes(NAN_TOPIC), 'stale 3 s after its last message')
        self.assertGreater(time.monotonic() - last_sent, 2.5, 'not stale before 3 s')
        self.wait(HISTORY_S + 5.0, lambda d: not self.cards_with(NAN_TOPIC), 'away after ~history_s')
        self.assertEqual(len(self.cards()), len(ROBOTS) + len(SECOND_HOST_ROBOTS), 'the robots stay')

    def cards_with(self, topic):
        return self.driver.find_elements(By.CSS_SELECTOR, card_selector(topic))

    def test_8_a_port_in_use_stops_a_second_dashboard_with_one_line(self):
        result = subprocess.run(node_command('battery_dashboard.py') + ['__name:=second_dashboard',
                                                                       '_port:=%d' % self.port],
                                capture_output=True, text=True, timeout=60.0)
        output = result.stdout + result.stderr
        self.assertNotEqual(result.returncode, 0, output)
        fatal = [line for line in output.splitlines() if 'FATAL' in line]
        self.assertEqual(len(fatal), 1, output)
        self.assertIn(str(self.port), fatal[0])
        self.assertIn('in use', fatal[0])
        self.assertNotIn('Traceback', output)

    def test_9_a_second_fleet_host_on_the_one_states_topic_shows_every_robot(self):
        """The second host (setUpClass) has published its robots on /battery_fleet/states beside the fleet
        host's robot0..robot4 since the start: every robot shown, none stale, each names its host."""
        self.assertGreater(time.monotonic() - self.second_host.started, 4.0, 'longer than the 3 s to stale')
        topics = [topic_of(robot) for robot in ROBOTS + SECOND_HOST_ROBOTS]
        self.wait(5.0, lambda d: all(self.cards_with(topic) for topic in topics), 'a card per robot of both hosts')
        self.assertEqual(self.field(topic_of('zz_fleet_b'), 'percentage'), '60.0 %')
        self.assertEqual([topic for topic in topics if 'stale' in self.classes(topic)], [], 'none stale')
        status, body = self.request('/api/batteries')
        self.assertEqual(status, 200)
        hosts = {battery['topic']: battery['host'] for battery in json.loads(body)['batteries']}
        self.assertEqual([hosts[topic] for topic in topics],
                         ['/battery_fleet'] * len(ROBOTS) + [rospy.get_name()] * len(SECOND_HOST_ROBOTS))

if __name__ == '__main__':
    rostest.rosrun('battery_simulator', 'test_dashboard', TestDashboard)
