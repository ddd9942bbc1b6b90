"""The dashboard's web server (tornado, no rospy): static pages, one websocket, a few JSON calls.

Pages are static files (``static/``); Chart.js is the distribution's own
(``/usr/share/javascript/chart.js``). The live channel ``/live`` sends every
battery once, then, a few times a second, only the batteries that changed.
Every request whose ``Host`` or ``Origin`` is not the dashboard's own address
gets 403, so a web site in the same browser cannot read or drive it (DNS
rebinding, cross-site requests). ``/api/control`` exists only with controls
on, and calls nothing but set_state, set_charging and inject_fault with
checked values.
"""
import collections
import datetime
import json
import logging
import math
import os
import re
import socket
import threading
import time
import urllib.parse

import tornado.gen
import tornado.ioloop
import tornado.util
import tornado.web
import tornado.websocket

from battery_simulator.core.battery_model import MIN_STATE_OF_HEALTH, SET_STATE_TEMPERATURE_C
from battery_simulator.web.dashboard_model import FAULTS, DashboardModel

#: resolved: a symlinked install (colcon --symlink-install) serves the files it links to, which tornado >= 6.5
#: refuses outside the directory it was given
STATIC_DIR = os.path.join(os.path.dirname(os.path.realpath(__file__)), 'static')
CHART_JS_DIR = '/usr/share/javascript/chart.js'
CHART_JS_FILE = 'chart.min.js'   # what battery.html loads from CHART_JS_DIR
PUSH_PERIOD_S = 0.25           # the page hears of a change within this (plus the network)
CONTROLS_SECTION = re.compile(r'\s*<section class="controls".*?</section>', re.S)
MAX_UNSENT_PUSHES = 240        # a page this many pushes (a minute) behind is closed, not buffered for
SECURITY_HEADERS = {
    'Content-Security-Policy': "default-src 'self'; style-src 'self' 'unsafe-inline'; img-src 'self' data:; "
                               "frame-ancestors 'none'",
    'X-Frame-Options': 'DENY',
    'X-Content-Type-Options': 'nosniff',
    'Referrer-Policy': 'no-referrer',
}
#: set_state's ranges, inclusive, as the simulator checks them (core/battery_model.py); an empty field is NaN:
#: left as it is
SET_STATE_RANGES = {'percentage': (0.0, 100.0), 'temperature_c': SET_STATE_TEMPERATURE_C,
                    'state_of_health': (MIN_STATE_OF_HEALTH, 1.0)}
CONTROL_ACTIONS = ('set_state', 'set_charging', 'inject_fault')
#: what a control's service call came to (the hub's call_service returns one with its message)
SERVICE_OK, SERVICE_REFUSED, SERVICE_UNREACHABLE = 'ok', 'refused', 'unreachable'
CALL_TIMEOUT_S = 10.0           # a control's service call without an answer by then: 504
MAX_URI_BYTES = 8192            # longer: 414 (the server reads headers up to MAX_HEADER_BYTES to say so)
MAX_HEADER_BYTES = 1024 * 1024
REQUEST_LOG_PERIOD_S = 10.0     # refused or failed requests: one line, then their count every this
#: tornado's loggers of its own warnings and errors (the node writes them to the ROS log)
TORNADO_LOGGERS = ('tornado.application', 'tornado.general')


# -- the checks (plain functions, unit-tested) -----------------------------------------

def own_addresses(host, port):
    """Every 'name:port' under which a browser may reach this dashboard.

    127.0.0.1, localhost and [::1] always; the configured ~host; bound to every
    interface (0.0.0.0 or ::), also this machine's names and addresses.
    """
    names = {'127.0.0.1', 'localhost', '[::1]', host if ':' not in host else '[%s]' % host}
    if host in ('0.0.0.0', '::', ''):
        names.update((socket.gethostname(), socket.getfqdn()))
        try:
            names.update(socket.gethostbyname_ex(socket.gethostname())[2])
        except OSError:
            pass
    addresses = {'%s:%d' % (name.lower(), port) for name in names if name}
    if port == 80:
        addresses.update(name.lower() for name in names if name)
    return addresses


def origin_address(origin):
    """'http://127.0.0.1:8090' -> '127.0.0.1:8090' (None for anything but http with a host)."""
    parsed = urllib.parse.urlsplit(origin or '')
    if parsed.scheme != 'http' or not parsed.netloc:
        return None
    return parsed.netloc.lower()


def request_allowed(host_header, origin_header, addresses):
    """True when Host is one of ``addresses`` and Origin, if the browser sent one, too."""
    if (host_header or '').lower() not in addresses:
        return False
    return origin_header is None or origin_address(origin_header) in addresses


def bad_static_path(url_path):
    """True for a static path with a character no file name of ours has (NUL and the other control
    characters): refused with 400 before it reaches the file system."""
    return any(ord(character) < 0x20 or ord(character) == 0x7f for character in url_path)


def _number(value, name, low, high, blank_is_nan=False):
    if blank_is_nan and (value is None or value == ''):
        return math.nan
    if isinstance(value, bool):
        raise ValueError('%s must be a number' % name)
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise ValueError('%s must be a number' % name) from None
    if not (low <= number <= high):
        raise ValueError('%s must be in [%g, %g], not %g' % (name, low, high, number))
    return number


def control_request(body):
    """Check a control request from the page: (action, arguments), or ValueError with the reason.

    {"action": "set_state", "percentage": 15, "temperature_c": "", "state_of_health": ""}
    {"action": "set_charging", "charging": true}
    {"action": "inject_fault", "fault": "overheat", "active": true}
    """
    if not isinstance(body, dict):
        raise ValueError('a JSON object is expected')
    action = body.get('action')
    if action == 'set_state':
        arguments = {name: _number(body.get(name), name, low, high, blank_is_nan=True)
                     for name, (low, high) in SET_STATE_RANGES.items()}
        if all(math.isnan(value) for value in arguments.values()):
            raise ValueError('set_state needs at least one value')
        return action, arguments
    if action == 'set_charging':
        if not isinstance(body.get('charging'), bool):
            raise ValueError('charging must be true or false')
        return action, {'charging': body['charging']}
    if action == 'inject_fault':
        if body.get('fault') not in FAULTS:
            raise ValueError('fault must be one of %s' % ', '.join(FAULTS))
        if not isinstance(body.get('active'), bool):
            raise ValueError('active must be true or false')
        return action, {'fault': body['fault'], 'active': body['active']}
    raise ValueError('action must be one of %s' % ', '.join(CONTROL_ACTIONS))


def chart_library_problem(directory=None):
    """The start-up warning when the chart library is missing (None when it is there): the battery pages
    then say so where the charts would be."""
    path = os.path.join(directory or CHART_JS_DIR, CHART_JS_FILE)
    if os.path.isfile(path):
        return None
    return ('the chart library is missing (%s; install the Debian package libjs-chart.js): the battery pages say '
            'so instead of drawing charts' % path)


def to_json(data):
    """JSON that a browser parses: NaN and infinities (JSON has none) become null."""
    try:
        return json.dumps(data, allow_nan=False, separators=(',', ':'))
    except ValueError:
        return json.dumps(_without_nan(data), allow_nan=False, separators=(',', ':'))


def _without_nan(data):
    if isinstance(data, float):
        return data if math.isfinite(data) else None
    if isinstance(data, dict):
        return {key: _without_nan(value) for key, value in data.items()}
    if isinstance(data, (list, tuple)):
        return [_without_nan(value) for value in data]
    return data


# -- the shared state ---------------------------------------------------------------------

class Hub:
    """The model behind one lock (ROS callbacks write, the web thread reads), and the open pages."""

    def __init__(self, history_s, allow_control, call_service=None, clock=time.time):
        self.lock = threading.Lock()
        self.model = DashboardModel(history_s)
        self.allow_control = allow_control
        self.call_service = call_service   # (battery topic, action, arguments) -> (success, message)
        self.call_timeout_s = CALL_TIMEOUT_S
        self.clock = clock
        self.pages = set()

    def push(self):
        """Send what changed to every open page (called every PUSH_PERIOD_S on the web thread)."""
        with self.lock:
            now = self.clock()
            changed, removed = self.model.tick(now, views=bool(self.pages))
        if self.pages and (changed or removed):
            message = to_json({'type': 'update', 'now': now, 'batteries': changed, 'removed': removed})
            for page in list(self.pages):
                page.send(message)

    def snapshot_message(self):
        with self.lock:
            now = self.clock()
            batteries = self.model.snapshot(now)
        return to_json({'type': 'snapshot', 'now': now, 'history_s': self.model.history_s,
                        'allow_control': self.allow_control, 'faults': FAULTS, 'batteries': batteries})


# -- the handlers -------------------------------------------------------------------------

class _Guard:
    """403 unless Host (and Origin, if sent) is the dashboard's own address; 414 for an absurd URI;
    security headers."""

    def prepare(self):
        # no log message in these errors: tornado would say each (a probe sends hundreds); RequestLog says them
        if len(self.request.uri) > MAX_URI_BYTES:
            raise tornado.web.HTTPError(414)
        if not request_allowed(self.request.headers.get('Host'), self.request.headers.get('Origin'),
                               self.settings['own_addresses']):
            raise tornado.web.HTTPError(403)

    def set_default_headers(self):
        for name, value in SECURITY_HEADERS.items():
            self.set_header(name, value)

    def log_exception(self, typ, value, tb):
        """Nothing of its own: RequestLog says every refused or failed request, the first at once and the
        rest as a count (tornado would write a line for each 403 of a path traversal, a traceback for each
        500). A failure that is not an HTTPError (a defect: no request may cause one) is named in
        RequestLog's line; its traceback goes to tornado's log at debug level."""
        if not isinstance(value, tornado.web.HTTPError):
            self.failure = '%s: %s' % (typ.__name__, value)
            logging.getLogger('tornado.application').debug('request failed: %s', self.request.uri,
                                                           exc_info=(typ, value, tb))


class PageHandler(_Guard, tornado.web.RequestHandler):
    def initialize(self, page):
        self.page = page

    def get(self):
        self.set_header('Content-Type', 'text/html; charset=utf-8')
        self.set_header('Cache-Control', 'no-cache')
        with open(os.path.join(STATIC_DIR, self.page), encoding='utf-8') as stream:
            page = stream.read()
        if not self.settings['hub'].allow_control:   # read-only: no control element in the page at all
            page = CONTROLS_SECTION.sub('', page)
        self.write(page)


class NotFoundHandler(_Guard, tornado.web.RequestHandler):
    """Any other path: 403 for a foreign Host or Origin (as everywhere), else 404."""

    def prepare(self):
        super().prepare()
        raise tornado.web.HTTPError(404)


class GuardedStaticHandler(_Guard, tornado.web.StaticFileHandler):
    def set_default_headers(self):
        _Guard.set_default_headers(self)

    def parse_url_path(self, url_path):
        """400 for a path no file can have (a NUL or another control character: tornado >= 6.5 answered
        ``/static/%00`` with a traceback and 500); tornado's own checks refuse the rest (403 outside the
        directory, 404 for no such file)."""
        if not bad_static_path(url_path):
            return super().parse_url_path(url_path)
        raise tornado.web.HTTPError(400)

    def set_extra_headers(self, path):
        self.set_header('Cache-Control', 'no-cache')   # a new version of the package shows at once


class ApiHandler(_Guard, tornado.web.RequestHandler):
    def send_json(self, data, status=200):
        self.set_status(status)
        self.set_header('Content-Type', 'application/json')
        self.set_header('Cache-Control', 'no-store')
        self.finish(to_json(data))


class BatteriesHandler(ApiHandler):
    def get(self):
        self.set_header('Content-Type', 'application/json')
        self.finish(self.settings['hub'].snapshot_message())


class HistoryHandler(ApiHandler):
    def get(self):
        hub = self.settings['hub']
        topic = self.get_query_argument('topic', '')
        with hub.lock:
            history = hub.model.history(topic, hub.clock())
        if history is None:
            self.send_json({'error': 'no battery %s' % topic}, 404)
        else:
            self.send_json({'topic': topic, 'history_s': hub.model.history_s, 'now': hub.clock(),
                            'history': history})


class ControlHandler(ApiHandler):
    async def post(self):
        hub = self.settings['hub']
        if not hub.allow_control or hub.call_service is None:
            self.send_json({'success': False, 'message': 'controls are off (~allow_control false)'}, 403)
            return
        if not self.request.headers.get('Content-Type', '').startswith('application/json'):
            self.send_json({'success': False, 'message': 'Content-Type must be application/json'}, 415)
            return
        try:
            body = json.loads(self.request.body or b'null')
            action, arguments = control_request(body)
        except ValueError as error:
            self.send_json({'success': False, 'message': str(error)}, 400)
            return
        topic = body.get('topic')
        if not isinstance(topic, str):
            self.send_json({'success': False, 'message': 'topic must be a topic name'}, 400)
            return
        with hub.lock:
            record = hub.model.records.get(topic)
            has_controls = record is not None and record.has_controls
        if not has_controls:
            self.send_json({'success': False, 'message': 'no simulated battery %s' % topic}, 404)
            return
        call = tornado.ioloop.IOLoop.current().run_in_executor(None, hub.call_service, topic, action, arguments)
        try:
            outcome, message = await tornado.gen.with_timeout(datetime.timedelta(seconds=hub.call_timeout_s), call)
        except tornado.util.TimeoutError:   # a service that hangs: the page hears so (the call runs on)
            self.send_json({'success': False, 'message': 'no answer from the %s service of %s within %g s'
                            % (action, topic, hub.call_timeout_s)}, 504)
            return
        # refused: the user's value (4xx, with the service's reason); unreachable: the simulator's side (502)
        self.send_json({'success': outcome == SERVICE_OK, 'message': message},
                       {SERVICE_OK: 200, SERVICE_REFUSED: 422}.get(outcome, 502))


class LiveSocket(_Guard, tornado.websocket.WebSocketHandler):
    """/live: a snapshot, then the changes. Nothing the page sends is read."""

    def check_origin(self, origin):
        return origin_address(origin) in self.settings['own_addresses']

    def open(self):
        self._unsent = 0
        hub = self.settings['hub']
        self.set_nodelay(True)
        self.write_message(hub.snapshot_message())
        hub.pages.add(self)

    def send(self, message):
        """Send a change; a page that has not taken MAX_UNSENT_PUSHES of them (a stalled tab) is closed
        rather than buffered for without end: it reconnects and starts again from a snapshot."""
        if self._unsent >= MAX_UNSENT_PUSHES:
            self.settings['hub'].pages.discard(self)
            self.close(1013, 'too far behind')
            return
        try:
            sent = self.write_message(message)
        except tornado.websocket.WebSocketClosedError:
            self.settings['hub'].pages.discard(self)
            return
        self._unsent += 1
        sent.add_done_callback(self._on_sent)

    def _on_sent(self, _future):
        self._unsent -= 1

    def on_message(self, message):
        pass

    def on_close(self):
        self.settings['hub'].pages.discard(self)


class RequestLog:
    """Tornado's request log: nothing for success; a refused or failed request (status 400 or more) is
    said at once when none was said in the last REQUEST_LOG_PERIOD_S, else counted and said in one line
    at the end of that period (a probe sends hundreds: 403 for a foreign Host or Origin, 404, 414).
    ``warn(text)`` writes a line; ``call_later(delay_s, function)`` runs the count's line later (by
    default on the current IOLoop)."""

    def __init__(self, warn, call_later=None):
        self._warn = warn
        self._call_later = call_later or (lambda delay_s, function:
                                          tornado.ioloop.IOLoop.current().call_later(delay_s, function))
        self._counts = collections.Counter()   # status -> requests not said yet
        self._last = ''
        self._quiet = False                    # within a period after a line: count, say at its end

    def __call__(self, handler):
        status = handler.get_status()
        if status < 400:
            return
        request = handler.request
        text = '%d %s %s' % (status, request.method, request.uri[:200])
        if status == 403:
            text += ' (Host %r, Origin %r)' % (request.headers.get('Host'), request.headers.get('Origin'))
        failure = getattr(handler, 'failure', None)
        if failure:
            text += ' (%s)' % failure[:200]
        if self._quiet:
            self._counts[status] += 1
            self._last = text
            return
        self._warn('request refused: %s' % text if status < 500 else 'request failed: %s' % text)
        self._start_period()

    def _start_period(self):
        self._quiet = True
        self._call_later(REQUEST_LOG_PERIOD_S, self._end_period)

    def _end_period(self):
        if not self._counts:
            self._quiet = False
            return
        self._warn('%d more request(s) refused or failed in the last %.0f s (%s); the last: %s' % (
            sum(self._counts.values()), REQUEST_LOG_PERIOD_S,
            ', '.join('%d x %d' % (count, status) for status, count in sorted(self._counts.items())), self._last))
        self._counts.clear()
        self._start_period()


def bridge_tornado_logs(warn, error):
    """Tornado's own warnings and errors (a handler that failed, a malformed request) to ``warn(text)`` /
    ``error(text)``; its access log off (RequestLog says what matters)."""
    class Bridge(logging.Handler):
        def emit(self, record):
            (error if record.levelno >= logging.ERROR else warn)(self.format(record))
    for name in TORNADO_LOGGERS:
        logger = logging.getLogger(name)
        logger.addHandler(Bridge(logging.WARNING))
        logger.propagate = False
    logging.getLogger('tornado.access').setLevel(logging.CRITICAL)


def make_app(hub, host, port, warn=None, request_log=None):
    """The tornado application: pages, static files, Chart.js, the API and /live. ``warn(text)``: where
    failed and refused requests are said (a RequestLog, or ``request_log``)."""
    return tornado.web.Application([
        (r'/', PageHandler, {'page': 'index.html'}),
        (r'/battery', PageHandler, {'page': 'battery.html'}),
        (r'/static/(.*)', GuardedStaticHandler, {'path': STATIC_DIR}),
        (r'/javascript/chart\.js/(.*)', GuardedStaticHandler, {'path': CHART_JS_DIR}),
        (r'/api/batteries', BatteriesHandler),
        (r'/api/history', HistoryHandler),
        (r'/api/control', ControlHandler),
        (r'/live', LiveSocket),
    ], hub=hub, own_addresses=own_addresses(host, port), websocket_ping_interval=20,
        default_handler_class=NotFoundHandler, log_function=request_log or RequestLog(warn or _no_line))


def _no_line(text):
    pass


def server_options():
    """The HTTP server's options: headers up to MAX_HEADER_BYTES are read, so that a longer URI than
    MAX_URI_BYTES is answered 414 rather than the connection closed without a status."""
    return {'max_header_size': MAX_HEADER_BYTES}


def start_pushing(hub):
    """Push the changes every PUSH_PERIOD_S on the current IOLoop."""
    pusher = tornado.ioloop.PeriodicCallback(hub.push, PUSH_PERIOD_S * 1000.0)
    pusher.start()
    return pusher
