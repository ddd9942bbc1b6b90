"""The dashboard's battery page without the distribution's chart library (libjs-chart.js has no rosdep
key: a ROS user's install may lack it) says so where the charts would be. The ROS-free app on a real
socket, read by headless Debian Chromium; no ROS."""
import asyncio
import os
import shutil
import socket
import tempfile
import threading
import time

import pytest

webdriver = pytest.importorskip('selenium.webdriver')
from selenium.webdriver.chrome.service import Service  # noqa: E402
from selenium.webdriver.common.by import By  # noqa: E402
from selenium.webdriver.support.ui import WebDriverWait  # noqa: E402

from battery_simulator.web import dashboard_app as app  # noqa: E402

TOPIC = '/robot3/battery_status'
pytestmark = pytest.mark.skipif(shutil.which('chromedriver') is None, reason='Debian chromium-driver not installed')


def free_port():
    with socket.socket() as probe:
        probe.bind(('127.0.0.1', 0))
        return probe.getsockname()[1]


@pytest.fixture
def dashboard(tmp_path, monkeypatch):
    monkeypatch.setattr(app, 'CHART_JS_DIR', str(tmp_path / 'no-chart-js'))   # the library is missing
    port, started, loop = free_port(), threading.Event(), {}

    def serve():
        asyncio.set_event_loop(asyncio.new_event_loop())
        import tornado.ioloop
        hub = app.Hub(600.0, allow_control=False)
        now = time.time()   # the hub's clock: a battery heard long ago would be dropped
        hub.model.add(TOPIC, now)
        hub.model.on_battery(TOPIC, dict(percentage=0.6, voltage=11.5, current=-1.5, temperature=25.0, charge=1.8,
                                         capacity=3.0, design_capacity=3.0, power_supply_status=2,
                                         power_supply_health=1, location='base', serial_number='S1'), now)
        app.make_app(hub, '127.0.0.1', port).listen(port, address='127.0.0.1', **app.server_options())
        app.start_pushing(hub)
        loop['loop'] = tornado.ioloop.IOLoop.current()
        started.set()
        loop['loop'].start()
    thread = threading.Thread(target=serve, daemon=True)
    thread.start()
    assert started.wait(10.0), 'the app did not start'
    yield 'http://127.0.0.1:%d' % port
    loop['loop'].add_callback(loop['loop'].stop)
    thread.join(5.0)


@pytest.fixture
def chromium_temporary():
    """A directory for Chromium's own temporary directories (it leaves one in TMPDIR at every quit), removed
    after; short: its socket's path must fit a Unix socket address (pytest's tmp_path does not)."""
    temporary = tempfile.mkdtemp(prefix='test_dashboard_app_')
    yield temporary
    shutil.rmtree(temporary, ignore_errors=True)


def test_a_battery_page_without_the_chart_library_says_so(dashboard, chromium_temporary):
    options = webdriver.ChromeOptions()
    for argument in ('--headless=new', '--no-sandbox', '--disable-gpu', '--disable-background-networking'):
        options.add_argument(argument)
    driver = webdriver.Chrome(options=options, service=Service('/usr/bin/chromedriver',
                                                               env=dict(os.environ, TMPDIR=chromium_temporary)))
    try:
        driver.get(dashboard + '/battery?topic=%2Frobot3%2Fbattery_status')
        notes = WebDriverWait(driver, 20.0).until(
            lambda d: d.find_elements(By.CSS_SELECTOR, '[data-chart-missing]') or None)
        assert len(notes) == 4 and all('chart library is missing' in note.text for note in notes), \
            [note.text for note in notes]
        assert not driver.find_elements(By.CSS_SELECTOR, 'canvas[data-chart]'), 'no empty charts'
        WebDriverWait(driver, 10.0).until(
            lambda d: d.find_element(By.CSS_SELECTOR, '[data-field="percentage"]').text == '60.0 %')
    finally:
        driver.quit()
