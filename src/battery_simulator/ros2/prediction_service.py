"""The ROS side of ``battery_simulator/predict`` on ROS 2 (ros1/prediction_service.py's twin): a plan is answered
by the process's prediction workers (core/prediction_worker.py), off the path of the batteries' updates.

``predict`` never delays the battery nor another robot of the process: its
callback is a coroutine that hands the plan to the workers from a thread of
its own and waits without blocking the executor, which keeps stepping every
battery meanwhile.

A service's answers go out at least ANSWER_GAP_S apart. rmw_fastrtps sends
every response of a service to every client of that service (each client
keeps the one for it), and a client's response reader keeps the last
``depth`` of them (10 by default): 40 clients of one process asking at once
got their refusals in one burst (the requests beyond a robot's 4 are refused
together after 1 s) and a client lost its own answer when 10 others came
before it took it (measured: the server sent all 80 responses of the forty
test, the probe got 29-39 of 40; a client that takes nothing until all are
sent gets exactly 10). Spaced, a client that takes its responses every 0.1 s
loses none. No answer waits for its turn past ANSWER_BY_S after its request
was taken (when more wait than would go by then, they are spread over the time
left), so every request is still answered within 10 s.
"""
import copy
import math
import queue
import threading
import time
from collections import deque

from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.qos import qos_profile_services_default
from rclpy.task import Future

from battery_simulator.core import prediction_worker
from battery_simulator.core.battery import MOTION_LOAD
from battery_simulator.core.prediction import FIELDS, MAX_SEGMENTS, PredictionError, too_many_segments
from battery_simulator.core.prediction_worker import Busy, WorkerFailed
from battery_simulator.ros2.events_executor import is_events_executor
from battery_simulator.ros2.startup import steady_clock
from battery_simulator.srv import Predict

#: predict's request queue: room for a burst between two takes of the executor (the pool's own bound)
PREDICT_QOS = copy.copy(qos_profile_services_default)
PREDICT_QOS.depth = prediction_worker.MAX_WAITING


def advertise(node, name, key, battery):
    """Advertise ``name`` (Predict) on ``node`` for the robot ``key``'s ``battery``; its PredictionService."""
    return PredictionService(node, name, key, battery)


class PredictionService:
    """One battery's predict service on ``node``."""

    def __init__(self, node, name, key, battery):
        self.node, self.battery, self._key = node, battery, key
        # its own reentrant group: a coroutine holds its callback group until it ends, so in the node's
        # (mutually exclusive) group one prediction held up every other request and the battery's contact,
        # cmd_vel and timers (contact -> battery_status 4.0 s), and requests waiting for it overflowed the
        # request queue (10: 40 predicts at once, 11 answered, 29 never). Here each is taken at once and
        # answered within 10 s (the plan's answer, or busy: prediction_worker's bounds).
        self._predict_group = ReentrantCallbackGroup()
        node.create_service(Predict, name, self._predict, qos_profile=PREDICT_QOS,
                            callback_group=self._predict_group)
        # the workers' answers are handed to the waiting requests in the executor's thread (rclpy's futures
        # are not for other threads: completed there, some requests were never answered), by the node's
        # AnswerHandout, made at the first predict (a fleet's executor waits on no more entities until one is asked)

    async def _predict(self, request, response):
        """What the plan would do, from a copy of the battery brought to now (changes nothing), computed in
        the process's prediction workers while the executor goes on."""
        model, behind_s = self.battery.model_for_prediction_pickled()
        arrays = tuple(_raw(getattr(request, name)) for name in FIELDS)
        answered = Future()
        handout = answer_handout(self.node, self._predict_group)
        asked_at = handout.asked()

        def ask():
            try:
                answer = ('ok', _in_workers(self._key, model, behind_s, arrays, request.charge_to_percentage))
            except (PredictionError, Busy, WorkerFailed) as error:
                answer = ('refused', str(error))
            except Exception as error:   # a defect must not leave the request unanswered
                answer = ('refused', 'the prediction failed: %s: %s' % (type(error).__name__, error))
            handout.put(self, asked_at, answered, answer)
        threading.Thread(target=ask, name='predict', daemon=True).start()
        kind, value = await answered
        if kind != 'ok':
            nan = math.nan
            response.success, response.message = False, value
            response.end_percentage = response.end_voltage_v = response.min_voltage_v = nan
            response.max_temperature_c = response.cut_off_at_s = response.charge_time_s = nan
            return response
        response.success, response.message, response.feasible = True, value.summary(), value.feasible
        response.end_percentage, response.end_voltage_v = value.end_percentage, value.end_voltage_v
        response.min_voltage_v, response.max_temperature_c = value.min_voltage_v, value.max_temperature_c
        response.cut_off_at_s, response.charge_time_s = value.cut_off_at_s, value.charge_time_s
        return response


#: how often the handout looks for answers (s) while a request waits under the EventsExecutor, or while an answer
#: waits for its turn
ANSWER_POLL_S = 0.02
#: one service's answers go at least this far apart (s): a client of it that takes its responses at least every
#: 0.1 s loses none with the default response queue (10), however many ask at once (see the module's docstring)
ANSWER_GAP_S = 0.1
#: an answer waits for its turn at most until this long (s) after its request was taken, the pool's own bound on a
#: caller's wait (the answers waiting are spread over the time left when they would not all go by then): the turns
#: add nothing to the time a request is answered in (10 s), also when more come at once than a service answers
#: ANSWER_GAP_S apart in that time (a run under a load average of 22 answered 4 of 40 at 10.1-10.4 s with 8 s here)
ANSWER_BY_S = prediction_worker.TIMEOUT_S
_HANDOUTS = {}   # node -> its AnswerHandout
_HANDOUTS_LOCK = threading.Lock()


def answer_handout(node, group):
    """The AnswerHandout of ``node`` (one a node: a fleet's robots share the host's), made at its first predict."""
    with _HANDOUTS_LOCK:
        if node not in _HANDOUTS:
            _HANDOUTS[node] = AnswerHandout(node, group, polled=is_events_executor(node.executor))
        return _HANDOUTS[node]


class AnswerHandout:
    """Hands the workers' answers (put from their threads) to the waiting requests in the executor's thread
    (rclpy's futures are not for other threads), one service's ANSWER_GAP_S apart (closer only when more wait than
    would go by ANSWER_BY_S after their requests were taken). Woken by a guard condition, or, under rclpy's
    EventsExecutor, which takes none ('Guard conditions not supported': the fleet host ended at its first predict),
    by a timer that runs only while a request waits; the same timer hands out the answers that wait their turn."""

    def __init__(self, node, group, polled, clock=time.monotonic):
        self._clock = clock
        self._answers = queue.SimpleQueue()   # (service, asked_at, future, answer) from the workers' threads
        # the executor's thread only, from here on
        self._turns = {}      # service -> deque of (asked_at, future, answer) waiting for their turn
        self._next_at = {}    # service -> when its next answer may go (clock s)
        self._waiting = 0     # requests asked and not answered
        self._polled = polled
        self._timer = node.create_timer(ANSWER_POLL_S, self._hand_out, callback_group=group, clock=steady_clock())
        self._timer.cancel()
        self._guard = None if polled else node.create_guard_condition(self._hand_out, callback_group=group)

    def asked(self):
        """A request came (the executor's thread): the time it came, for put."""
        self._waiting += 1
        self._keep_timer()
        return self._clock()

    def put(self, service, asked_at, answered, answer):
        """The answer to a request of ``service`` asked at ``asked_at``, for the future ``answered`` (any thread)."""
        self._answers.put((service, asked_at, answered, answer))
        if self._guard is not None:
            self._guard.trigger()

    def _hand_out(self):
        now = self._clock()
        while True:
            try:
                service, asked_at, answered, answer = self._answers.get_nowait()
            except queue.Empty:
                break
            self._turns.setdefault(service, deque()).append((asked_at, answered, answer))
        for service in list(self._turns):
            turn = self._turns[service]
            for late in [entry for entry in turn if now - entry[0] >= ANSWER_BY_S]:
                turn.remove(late)
                self._answer(late)
            due = self._next_at.get(service, now)
            if due < now - ANSWER_POLL_S:   # idle, or a late tick (a busy machine): the gap counts from now
                due = now
            while turn and due <= now:
                self._answer(turn.popleft())
                due += _gap(turn, now)
            self._next_at[service] = due
            if not turn:
                del self._turns[service]
        for service in [service for service, due in self._next_at.items() if due <= now and service not in self._turns]:
            del self._next_at[service]
        self._keep_timer()

    def _answer(self, entry):
        _, answered, answer = entry
        self._waiting -= 1
        answered.set_result(answer)

    def _keep_timer(self):
        """The timer runs while an answer waits for its turn, or (EventsExecutor) while a request waits."""
        wanted = bool(self._turns) or (self._polled and self._waiting > 0)
        if wanted and self._timer.is_canceled():
            self._timer.reset()
        elif not wanted and not self._timer.is_canceled():
            self._timer.cancel()


def _gap(turn, now):
    """How long (s) after an answer the next of its service goes, ``turn`` waiting: ANSWER_GAP_S, or less when the
    answers waiting would not all go by ANSWER_BY_S after the earliest's request (spread over the time left)."""
    if not turn:
        return ANSWER_GAP_S
    left_s = min(asked_at for asked_at, _, _ in turn) + ANSWER_BY_S - now
    return min(ANSWER_GAP_S, max(0.0, left_s) / len(turn))


def _raw(values):
    """An array of the request as the workers take it: rclpy's array('d') as its bytes (one copy)."""
    return values.tobytes() if hasattr(values, 'tobytes') else tuple(values)


def _in_workers(key, model, behind_s, arrays, charge_to_percentage):
    """The Prediction of a plan for the robot ``key``, from the process's prediction workers (blocks)."""
    counts = [len(values) // 8 if isinstance(values, bytes) else len(values) for values in arrays]
    for name, count in zip(FIELDS, counts):
        if count > MAX_SEGMENTS:
            raise PredictionError(too_many_segments(name, count))
    job = prediction_worker.job(model, behind_s, (MOTION_LOAD,), arrays, charge_to_percentage)
    return prediction_worker.shared_pool().run(key, job, max(counts))


def start_workers():
    """The process's prediction workers, started now (an interpreter starts in the background)."""
    prediction_worker.shared_pool()


def stop_workers():
    prediction_worker.stop_shared_pool()
