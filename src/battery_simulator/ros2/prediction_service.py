"""The ROS side of ``battery_simulator/predict`` on ROS 2 (ros1/prediction_service.py's twin): a plan is answered
by the process's prediction workers (core/prediction_worker.py), off the path of the batteries' updates.

``predict`` never delays the battery nor another robot of the process: its
callback is a coroutine that hands the plan to the workers from a thread of
its own and waits without blocking the executor, which keeps stepping every
battery meanwhile.
"""
import copy
import math
import queue
import threading

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
        handout.asked()

        def ask():
            try:
                answer = ('ok', _in_workers(self._key, model, behind_s, arrays, request.charge_to_percentage))
            except (PredictionError, Busy, WorkerFailed) as error:
                answer = ('refused', str(error))
            handout.put(answered, answer)
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


#: how often a polled handout looks for answers while a request waits, s
ANSWER_POLL_S = 0.02
_HANDOUTS = {}   # node -> its AnswerHandout
_HANDOUTS_LOCK = threading.Lock()


def answer_handout(node, group):
    """The AnswerHandout of ``node`` (one a node: a fleet's robots share the host's), made at its first predict."""
    with _HANDOUTS_LOCK:
        if node not in _HANDOUTS:
            _HANDOUTS[node] = AnswerHandout(node, group, polled=is_events_executor(node.executor))
        return _HANDOUTS[node]


class AnswerHandout:
    """Hands the workers' answers (put from their threads) to the waiting requests in the executor's thread: woken
    by a guard condition, or, under rclpy's EventsExecutor, which takes none ('Guard conditions not supported':
    the fleet host ended at its first predict), by a timer that runs only while a request waits."""

    def __init__(self, node, group, polled):
        self._answers = queue.SimpleQueue()
        self._waiting = 0   # requests asked and not answered (the executor's thread only)
        if polled:
            self._timer = node.create_timer(ANSWER_POLL_S, self._hand_out, callback_group=group, clock=steady_clock())
            self._timer.cancel()
            self._guard = None
        else:
            self._timer = None
            self._guard = node.create_guard_condition(self._hand_out, callback_group=group)

    def asked(self):
        self._waiting += 1
        if self._timer is not None and self._timer.is_canceled():
            self._timer.reset()

    def put(self, answered, answer):
        self._answers.put((answered, answer))
        if self._guard is not None:
            self._guard.trigger()

    def _hand_out(self):
        while True:
            try:
                answered, answer = self._answers.get_nowait()
            except queue.Empty:
                break
            self._waiting -= 1
            answered.set_result(answer)
        if self._timer is not None and self._waiting <= 0:
            self._timer.cancel()


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
