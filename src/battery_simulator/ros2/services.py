"""The ``battery_simulator`` node's services on ROS 2 (ros1/services.py's twin): set_load, set_charging,
set_state, reset, inject_fault and predict.

A change is stepped and handed to the status front before the reply, so the
next ``battery_status`` shows it. ``predict`` never delays the battery nor
another robot of the process: its callback is a coroutine that hands the plan
to the process's prediction workers (core/prediction_worker.py, as ROS 1's)
from a thread of its own and waits without blocking the executor, which keeps
stepping every battery meanwhile.
"""
import math
import threading

from rclpy.task import Future
from std_srvs.srv import SetBool, Trigger

from battery_simulator.core import prediction_worker, topics
from battery_simulator.core.battery import MOTION_LOAD, BatteryError
from battery_simulator.core.prediction import FIELDS, MAX_SEGMENTS, PredictionError, too_many_segments
from battery_simulator.core.prediction_worker import Busy, WorkerFailed
from battery_simulator.srv import InjectFault, Predict, SetLoad, SetState


class BatteryServices:
    """One battery's services on ``node`` under ``namespace``; ``server`` is its BatterySimServer."""

    def __init__(self, node, namespace, server):
        self.node, self.server, self.battery = node, server, server.battery
        self._key = node.get_namespace().rstrip('/') + '/' + namespace
        ns = namespace
        node.create_service(SetLoad, ns + topics.SET_LOAD, self._set_load)
        node.create_service(SetBool, ns + topics.SET_CHARGING, self._set_charging)
        node.create_service(SetState, ns + topics.SET_STATE, self._set_state)
        node.create_service(Trigger, ns + topics.RESET, self._reset)
        node.create_service(InjectFault, ns + topics.INJECT_FAULT, self._inject_fault)
        node.create_service(Predict, ns + topics.PREDICT, self._predict)

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
        executor = self.node.executor

        def ask():
            try:
                answered.set_result(('ok', _in_workers(self._key, model, behind_s, arrays,
                                                       request.charge_to_percentage)))
            except (PredictionError, Busy, WorkerFailed) as error:
                answered.set_result(('refused', str(error)))
            if executor is not None:
                executor.wake()
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
