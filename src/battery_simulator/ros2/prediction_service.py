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
        # are not for other threads: completed there, some requests were never answered), woken by a guard
        # condition made at the first predict (a fleet's executor waits on no more entities until one is asked)
        self._answers = queue.SimpleQueue()
        self._answers_ready = None
        self._answers_lock = threading.Lock()

    async def _predict(self, request, response):
        """What the plan would do, from a copy of the battery brought to now (changes nothing), computed in
        the process's prediction workers while the executor goes on."""
        model, behind_s = self.battery.model_for_prediction_pickled()
        arrays = tuple(_raw(getattr(request, name)) for name in FIELDS)
        answered = Future()
        answers_ready = self._answers_guard()

        def ask():
            try:
                answer = ('ok', _in_workers(self._key, model, behind_s, arrays, request.charge_to_percentage))
            except (PredictionError, Busy, WorkerFailed) as error:
                answer = ('refused', str(error))
            self._answers.put((answered, answer))
            answers_ready.trigger()
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

    def _answers_guard(self):
        with self._answers_lock:
            if self._answers_ready is None:
                self._answers_ready = self.node.create_guard_condition(self._hand_out_answers,
                                                                       callback_group=self._predict_group)
            return self._answers_ready

    def _hand_out_answers(self):
        while True:
            try:
                answered, answer = self._answers.get_nowait()
            except queue.Empty:
                return
            answered.set_result(answer)


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
