"""The ``battery_simulator`` node's services on ROS 2 (ros1/services.py's twin): set_load, set_charging,
set_state, reset, inject_fault and predict.

A change is stepped and handed to the status front before the reply, so the
next ``battery_status`` shows it. ``predict`` never delays the battery nor
another robot of the process: its callback is a coroutine that hands the plan
to the process's prediction workers (core/prediction_worker.py, as ROS 1's)
from a thread of its own and waits without blocking the executor, which keeps
stepping every battery meanwhile.
"""
import copy
import math
import queue
import threading

from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.qos import qos_profile_services_default
from rclpy.task import Future
from std_srvs.srv import SetBool, Trigger

from battery_simulator.core import prediction_worker, ros_names
from battery_simulator.core.battery import MOTION_LOAD, BatteryError
from battery_simulator.core.prediction import FIELDS, MAX_SEGMENTS, PredictionError, too_many_segments
from battery_simulator.core.prediction_worker import Busy, WorkerFailed
from battery_simulator.srv import InjectFault, Predict, SetLoad, SetState


#: predict's request queue: room for a burst between two takes of the executor (the pool's own bound)
PREDICT_QOS = copy.copy(qos_profile_services_default)
PREDICT_QOS.depth = prediction_worker.MAX_WAITING


class BatteryServices:
    """One battery's services on ``node`` under ``namespace``; ``server`` is its BatterySimServer."""

    def __init__(self, node, namespace, server):
        self.node, self.server, self.battery = node, server, server.battery
        self._key = node.get_namespace().rstrip('/') + '/' + namespace
        ns = namespace
        node.create_service(SetLoad, ns + ros_names.SET_LOAD, self._set_load)
        node.create_service(SetBool, ns + ros_names.SET_CHARGING, self._set_charging)
        node.create_service(SetState, ns + ros_names.SET_STATE, self._set_state)
        node.create_service(Trigger, ns + ros_names.RESET, self._reset)
        node.create_service(InjectFault, ns + ros_names.INJECT_FAULT, self._inject_fault)
        # its own reentrant group: a coroutine holds its callback group until it ends, so in the node's
        # (mutually exclusive) group one prediction held up every other request and the battery's contact,
        # cmd_vel and timers (contact -> battery_status 4.0 s), and requests waiting for it overflowed the
        # request queue (10: 40 predicts at once, 11 answered, 29 never). Here each is taken at once and
        # answered within 10 s (the plan's answer, or busy: prediction_worker's bounds).
        self._predict_group = ReentrantCallbackGroup()
        node.create_service(Predict, ns + ros_names.PREDICT, self._predict, qos_profile=PREDICT_QOS,
                            callback_group=self._predict_group)
        # the workers' answers are handed to the waiting requests in the executor's thread (rclpy's futures
        # are not for other threads: completed there, some requests were never answered), woken by a guard
        # condition made at the first predict (a fleet's executor waits on no more entities until one is asked)
        self._answers = queue.SimpleQueue()
        self._answers_ready = None
        self._answers_lock = threading.Lock()

    def _service(self, response, change):
        """Run ``change()`` (the reply's text) on the battery, publish it, then reply; a refusal replies
        success false with the battery's reason and changes nothing."""
        try:
            self.battery.advance_to_now()
            response.message = change()
            response.success = True
        except BatteryError as error:
            response.success, response.message = False, str(error)
            return response
        self.server.update(publish_now=True)
        return response

    def _set_charging(self, request, response):
        connected = bool(request.data)
        return self._service(response, lambda: self.server.change_contact(connected, 'set_charging') or
                             'charger %s' % ('connected' if connected else 'disconnected'))

    def _set_load(self, request, response):
        return self._service(response, lambda: self.battery.set_load(request.name, request.power_w))

    def _set_state(self, request, response):
        return self._service(response, lambda: self.battery.set_state(
            request.percentage, request.temperature_c, request.state_of_health, request.gauge_error))

    def _reset(self, request, response):
        return self._service(response, self.battery.reset)

    def _inject_fault(self, request, response):
        return self._service(response, lambda: self.battery.inject_fault(request.fault, request.active))

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
