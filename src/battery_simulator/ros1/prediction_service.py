"""The ROS side of ``battery_simulator/predict``: requests whose plan a host never unpacks, answered by
the process's prediction workers (prediction_worker.py), off the path of the batteries' updates.

rospy deserializes a request in the service's thread before the handler sees
it, holding the GIL all along: 17 ms for 100,000 segments, 0.7 s for a
million. A RawPredictRequest instead reads the five arrays' lengths and
keeps their bytes (one copy), so a request beyond MAX_SEGMENTS is refused at
no cost and one within costs a copy; the worker unpacks and checks the plan.
The service is advertised as Predict (same type and MD5 sum): clients see no
difference.
"""
import math
import struct

import genpy
import rospy

from battery_simulator.core import prediction_worker
from battery_simulator.core.prediction_worker import Busy, WorkerFailed
from battery_simulator.core.prediction import FIELDS, MAX_SEGMENTS, PredictionError, too_many_segments
from battery_simulator.srv import Predict, PredictRequest, PredictResponse

_LENGTH = struct.Struct('<I')
_FLOAT64 = struct.Struct('<d')


class RawPredictRequest(PredictRequest):
    """A Predict request whose arrays stay as they came: ``raw_arrays`` (five bytes objects of
    little-endian float64, in FIELDS' order), or ``too_many`` (field, count) when one has more than
    MAX_SEGMENTS entries (then no array is kept). The array fields themselves stay empty."""

    def __init__(self, *args, **kwds):
        super().__init__(*args, **kwds)
        self.raw_arrays = None
        self.too_many = None

    def deserialize(self, str):   # genpy's argument name
        try:
            end = 0
            spans = []
            for name in FIELDS:
                (count,) = _LENGTH.unpack_from(str, end)
                end += _LENGTH.size
                spans.append((name, count, end))
                end += 8 * count
            (self.charge_to_percentage,) = _FLOAT64.unpack_from(str, end)
        except struct.error as error:
            raise genpy.DeserializationError(error)  # a short buffer
        self.too_many = next(((name, count) for name, count, _ in spans if count > MAX_SEGMENTS), None)
        if self.too_many is None:
            view = memoryview(str)
            self.raw_arrays = tuple(bytes(view[start:start + 8 * count]) for _, count, start in spans)
        return self


class RawPredict:
    """The service type Predict, with RawPredictRequest for the requests."""

    _type = Predict._type
    _md5sum = Predict._md5sum
    _request_class = RawPredictRequest
    _response_class = PredictResponse


def advertise(name, handler):
    """Advertise ``name`` (RawPredict) with ``handler(request)``; starts the process's workers (once) and
    ends them at shutdown."""
    start_workers()
    return rospy.Service(name, RawPredict, handler)


_shutdown_hooked = []


def start_workers():
    """The process's prediction workers: started at the first call, ended at rospy's shutdown."""
    if not _shutdown_hooked:
        _shutdown_hooked.append(True)
        rospy.on_shutdown(prediction_worker.stop_shared_pool)
    prediction_worker.shared_pool()


def answer(key, request, model_pickle, behind_s, dropped_loads=()):
    """The PredictResponse to ``request`` (a RawPredictRequest, or a PredictRequest) for the robot
    ``key``, from ``model_pickle`` (pickle.dumps of its model, ``behind_s`` s behind now; the loads
    ``dropped_loads`` are left out of the plan), computed in the process's prediction workers."""
    too_many = getattr(request, 'too_many', None)
    arrays = getattr(request, 'raw_arrays', None)
    if arrays is None:   # an unpacked request (tuples), as a caller in the process may give
        arrays = tuple(getattr(request, name) for name in FIELDS)
    counts = [len(values) // 8 if isinstance(values, bytes) else len(values) for values in arrays]
    if too_many is None and max(counts) > MAX_SEGMENTS:
        too_many = next((name, count) for name, count in zip(FIELDS, counts) if count > MAX_SEGMENTS)
    try:
        if too_many is not None:
            raise PredictionError(too_many_segments(*too_many))
        segments = max(counts)
        job = prediction_worker.job(model_pickle, behind_s, dropped_loads, arrays, request.charge_to_percentage)
        result = prediction_worker.shared_pool().run(key, job, segments)
    except (PredictionError, Busy, WorkerFailed) as error:
        nan = math.nan
        return PredictResponse(success=False, message=str(error), end_percentage=nan, end_voltage_v=nan,
                               min_voltage_v=nan, max_temperature_c=nan, cut_off_at_s=nan, charge_time_s=nan)
    return PredictResponse(success=True, message=result.summary(), feasible=result.feasible,
                           end_percentage=result.end_percentage, end_voltage_v=result.end_voltage_v,
                           min_voltage_v=result.min_voltage_v, max_temperature_c=result.max_temperature_c,
                           cut_off_at_s=result.cut_off_at_s, charge_time_s=result.charge_time_s)
