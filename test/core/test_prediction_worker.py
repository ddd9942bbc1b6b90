"""The prediction workers (core/prediction_worker.py): answers, bounds, fairness, crashes and ends.

Every worker process here is started by a pool of the test (or by a parent
process the test starts) and ended by its pool or by its pid; each test
stops its pool, which ends a long job at once.
"""
import math
import os
import pickle
import signal
import subprocess
import sys
import textwrap
import threading
import time
from array import array

import pytest

from battery_simulator.core import prediction_worker
from battery_simulator.core.battery_model import BatteryModel
from battery_simulator.core.config_files import preset
from battery_simulator.core.prediction import PredictionError, plan_from_arrays, predict
from battery_simulator.core.prediction_worker import Busy, PredictionPool, WorkerFailed

NAN = math.nan
PACK = preset('lg_hg2_3s1p')
BIG_PACK = preset('lg_hg2_7s4p')
#: a plan that keeps a worker busy for a second or two: 100,000 six-second power loads on a big pack
LONG = ([6.0] * 100_000, [], [1.0 + (k % 7) for k in range(100_000)], [], [])
#: an hour of different one-second loads
HOUR = ([1.0] * 3600, [], [(k * 7919) % 20 * 0.5 for k in range(3600)], [0.1 * (k % 3) for k in range(3600)],
        [0.3 * (k % 5) for k in range(3600)])


def job(model, arrays, charge_to_percentage=NAN, dropped=()):
    """A worker's job: the model pickled, the arrays as raw float64 bytes (as the service gives them)."""
    return prediction_worker.job(pickle.dumps(model), 0.0, dropped,
                                 [array('d', values).tobytes() for values in arrays], charge_to_percentage)


def segments_of(arrays):
    return max(len(values) for values in arrays)


@pytest.fixture
def pools():
    """Pools made by a test, each stopped (its workers ended) after it."""
    made = []

    def make(**settings):
        pool = PredictionPool(**dict(dict(restart_gap_s=0.05), **settings))
        pool.start()
        made.append(pool)
        return pool
    yield make
    for pool in made:
        pool.stop()
        assert pool.worker_pids() == []


def in_thread(function, *args):
    """Run ``function(*args)`` in a thread; a dict that gets 'result' or 'error', and 'at' (monotonic)."""
    outcome = {}

    def run():
        try:
            outcome['result'] = function(*args)
        except Exception as error:   # the test looks at it
            outcome['error'] = error
        outcome['at'] = time.monotonic()
    thread = threading.Thread(target=run, daemon=True)
    thread.start()
    outcome['thread'] = thread
    return outcome


def wait_for(condition, timeout_s, what):
    deadline = time.monotonic() + timeout_s
    while not condition():
        assert time.monotonic() < deadline, 'timed out after %g s waiting for %s' % (timeout_s, what)
        time.sleep(0.01)


def ended(pid):
    """Whether ``pid`` has ended (gone, or a zombie nobody reaped yet)."""
    try:
        with open('/proc/%d/stat' % pid) as stream:
            return stream.read().rsplit(')', 1)[1].split()[0] == 'Z'
    except OSError:
        return True


# -- answers ---------------------------------------------------------------------------

def test_a_worker_answers_as_the_core_does_from_raw_arrays_and_a_pickled_model(pools):
    pool = pools()
    model = BatteryModel(PACK, 0.9)
    model.set_extra_load('payload', power_w=3.0)
    for charge in (NAN, 80.0):
        expected = predict(model, plan_from_arrays(*HOUR), charge)
        assert repr(pool.run('robot0', job(model, HOUR, charge), 3600)) == repr(expected)


def test_the_worker_brings_the_copy_to_now_and_drops_the_named_loads(pools):
    pool = pools()
    model = BatteryModel(PACK, 0.9)
    model.set_extra_load('motion', power_w=20.0)
    raw = prediction_worker.job(pickle.dumps(model), 120.0, ('motion',),
                                [array('d', [600.0]).tobytes(), b'', b'', b'', b''], NAN)
    reference = pickle.loads(pickle.dumps(model))
    reference.step(120.0)
    reference.set_extra_load('motion')
    assert repr(pool.run('robot0', raw, 1)) == repr(predict(reference, [plan_from_arrays([600.0])[0]]))


def test_a_bad_plan_is_refused_with_the_core_s_message_and_the_worker_serves_on(pools):
    pool = pools()
    model = BatteryModel(PACK, 0.9)
    with pytest.raises(PredictionError) as error:
        pool.run('robot0', job(model, ([10.0, -1.0], [], [], [], [])), 2)
    assert str(error.value) == 'duration_s[1] = -1.0 is invalid: must be a number of seconds >= 0'
    pid = pool.worker_pids()
    assert pool.run('robot0', job(model, ([60.0], [], [], [], [])), 1).feasible
    assert pool.worker_pids() == pid, 'the same worker'


# -- bounds and turns ------------------------------------------------------------------

def test_a_robot_beyond_its_bound_gets_busy_after_a_short_wait_and_others_still_get_in(pools):
    pool = pools(per_key=1, admit_s=0.1)
    model = BatteryModel(BIG_PACK, 1.0)
    long = in_thread(pool.run, 'robot0', job(model, LONG), 100_000)
    wait_for(lambda: pool.jobs('robot0')[0] == 1, 30.0, 'the long job')
    asked = time.monotonic()
    with pytest.raises(Busy) as error:
        pool.run('robot0', job(model, HOUR), 3600)
    assert str(error.value) == ('busy, try again: 1 predictions of robot0 are waiting or running (at most 1)')
    assert time.monotonic() - asked < 5.0
    assert pool.run('robot1', job(model, HOUR), 3600).end_percentage > 0.0, 'another robot gets in'
    assert 'at' not in long, 'the long job still runs'


def test_the_total_bounds_answer_busy(pools):
    pool = pools(max_waiting=1, admit_s=0.05)
    model = BatteryModel(BIG_PACK, 1.0)
    in_thread(pool.run, 'robot0', job(model, LONG), 100_000)
    wait_for(lambda: pool.jobs()[0] == 1, 30.0, 'the long job')
    with pytest.raises(Busy, match='busy, try again: 1 predictions are waiting or running in this process '
                                   r'\(at most 1\)'):
        pool.run('robot1', job(model, HOUR), 3600)
    pool = pools(max_queued_segments=150_000, admit_s=0.05)
    in_thread(pool.run, 'robot0', job(model, LONG), 100_000)
    wait_for(lambda: pool.jobs()[0] == 1, 30.0, 'the long job')
    with pytest.raises(Busy, match='segments'):
        pool.run('robot1', job(model, LONG), 100_000)


def test_a_robot_s_flood_leaves_a_worker_to_the_others(pools):
    pool = pools()
    model = BatteryModel(BIG_PACK, 1.0)
    long = in_thread(pool.run, 'robot0', job(model, LONG), 100_000)
    wait_for(lambda: pool.jobs()[1] == ['robot0'], 30.0, 'the long job running')
    more = [in_thread(pool.run, 'robot0', job(model, LONG), 100_000) for _ in range(2)]
    assert pool.run('robot1', job(BatteryModel(PACK, 0.9), HOUR), 3600).end_percentage > 0.0
    assert 'at' not in long and all('at' not in m for m in more), 'robot1 was answered before robot0'
    assert len(pool.worker_pids()) == 2, 'a second worker took robot1'


def test_a_caller_waits_at_most_its_timeout(pools):
    pool = pools(workers=1)
    model = BatteryModel(BIG_PACK, 1.0)
    in_thread(pool.run, 'robot0', job(model, LONG), 100_000)
    wait_for(lambda: pool.jobs()[1] == ['robot0'], 30.0, 'the long job running')
    asked = time.monotonic()
    with pytest.raises(Busy, match=r'busy, try again: no answer within 0.2 s'):
        pool.run('robot1', job(model, HOUR), 3600, timeout_s=0.2)
    assert time.monotonic() - asked < 2.0
    assert pool.jobs('robot1')[0] == 0, 'the job that timed out is forgotten'


# -- crashes, hangs and ends -----------------------------------------------------------------

def test_a_worker_killed_during_a_job_fails_that_job_and_starts_again(pools):
    pool = pools(workers=1)
    model = BatteryModel(BIG_PACK, 1.0)
    long = in_thread(pool.run, 'robot0', job(model, LONG), 100_000)
    wait_for(lambda: pool.jobs()[1] == ['robot0'], 30.0, 'the long job running')
    time.sleep(0.2)   # sent to the worker (it runs for a second or more)
    (pid,) = pool.worker_pids()
    os.kill(pid, signal.SIGKILL)
    long['thread'].join(10.0)
    assert isinstance(long.get('error'), WorkerFailed), long
    assert str(long['error']) == ('the prediction worker ended (signal SIGKILL) during this prediction; it starts '
                                  'again for the next one')
    assert pool.run('robot0', job(model, HOUR), 3600).end_percentage > 0.0
    assert pool.worker_pids() != [pid]


def test_a_worker_ended_by_sigterm_between_jobs_is_started_again(pools):
    pool = pools(workers=1)
    model = BatteryModel(PACK, 0.9)
    pool.run('robot0', job(model, HOUR), 3600)
    (pid,) = pool.worker_pids()
    os.kill(pid, signal.SIGTERM)
    wait_for(lambda: pool.worker_pids() == [], 2.0, 'the worker to end')
    assert pool.run('robot0', job(model, HOUR), 3600).end_percentage > 0.0
    assert pool.worker_pids() and pool.worker_pids() != [pid]


def test_a_job_longer_than_the_job_timeout_ends_its_worker(pools):
    pool = pools(workers=1, job_timeout_s=0.2)
    model = BatteryModel(BIG_PACK, 1.0)
    wait_for(lambda: pool.worker_pids(), 5.0, 'the worker')
    (pid,) = pool.worker_pids()
    with pytest.raises(WorkerFailed, match='the prediction took longer than 0.2 s: its worker was ended'):
        pool.run('robot0', job(model, LONG), 100_000)
    assert ended(pid)
    # the next job gets a worker started again (the bound raised: a fresh worker's first job includes its start,
    # which a loaded machine can make longer than 0.2 s)
    pool.job_timeout_s = 10.0
    assert pool.run('robot0', job(BatteryModel(PACK, 0.9), ([60.0], [], [], [], [])), 1).feasible


def test_stop_ends_the_workers_and_refuses_what_waits(pools):
    pool = pools(workers=1)
    model = BatteryModel(BIG_PACK, 1.0)
    running = in_thread(pool.run, 'robot0', job(model, LONG), 100_000)
    waiting = in_thread(pool.run, 'robot1', job(model, HOUR), 3600)
    wait_for(lambda: pool.jobs()[0] == 2, 5.0, 'both jobs')
    pids = pool.worker_pids()
    stopped = time.monotonic()
    pool.stop()
    assert time.monotonic() - stopped < 2.0
    for outcome in (running, waiting):
        outcome['thread'].join(5.0)
        assert isinstance(outcome.get('error'), Busy) and 'shutting down' in str(outcome['error']), outcome
    assert all(ended(pid) for pid in pids)
    with pytest.raises(Busy, match='shutting down'):
        pool.run('robot0', job(model, HOUR), 3600)


PARENT = textwrap.dedent('''
    import os, signal, sys, threading, time, pickle
    from array import array
    from battery_simulator.core import prediction_worker
    from battery_simulator.core.battery_model import BatteryModel
    from battery_simulator.core.config_files import preset
    signal.signal(signal.SIGINT, lambda *_: os._exit(0))   # a node ends on SIGINT (and its workers follow)
    pool = prediction_worker.PredictionPool()
    pool.start()
    if sys.argv[1] == 'busy':   # a job the worker is busy with when the parent dies
        model = BatteryModel(preset('lg_hg2_7s4p'), 1.0)
        arrays = [array('d', [6.0] * 100000).tobytes(), b'', array('d', [3.0] * 100000).tobytes(), b'', b'']
        job = prediction_worker.job(pickle.dumps(model), 0.0, (), arrays, float('nan'))
        threading.Thread(target=pool.run, args=('robot0', job, 100000), daemon=True).start()
        while pool.jobs()[1] != ['robot0']:
            time.sleep(0.01)
        time.sleep(0.2)
    while not pool.worker_pids():
        time.sleep(0.01)
    print(pool.worker_pids()[0], flush=True)
    time.sleep(60)
''')


@pytest.mark.parametrize('busy, how', [('idle', signal.SIGKILL), ('busy', signal.SIGKILL),
                                       ('idle', signal.SIGINT)])
def test_a_worker_ends_with_its_parent_without_a_traceback(busy, how):
    """SIGKILL of the parent (idle worker: end of file; busy worker: its parent check), and SIGINT to the
    whole process group as Ctrl-C sends it (the worker ignores it and follows its parent)."""
    parent = subprocess.Popen([sys.executable, '-c', PARENT, busy], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                              text=True, start_new_session=True, env=dict(os.environ, PYTHONPATH=os.pathsep.join(
                                  path for path in sys.path if path)))
    try:
        worker = int(parent.stdout.readline())
        killed = time.monotonic()
        if how == signal.SIGINT:
            os.killpg(parent.pid, signal.SIGINT)
        else:
            os.kill(parent.pid, how)
        parent.wait(5.0)
        wait_for(lambda: ended(worker), 2.0, 'the worker %d to end' % worker)
        assert time.monotonic() - killed < 2.0
    finally:
        if parent.poll() is None:
            os.killpg(parent.pid, signal.SIGKILL)
        _, stderr = parent.communicate(timeout=10.0)
        if not ended(worker):
            os.kill(worker, signal.SIGKILL)
    assert 'Traceback' not in stderr and 'KeyboardInterrupt' not in stderr, stderr


# -- the service's raw requests --------------------------------------------------------------

def test_a_raw_request_keeps_the_arrays_bytes_and_refuses_too_many_before_unpacking():
    pytest.importorskip('genpy')
    service = pytest.importorskip('battery_simulator.ros1.prediction_service',
                                  reason='needs the devel space (tools/run_tests.sh)')
    import io
    from battery_simulator.core.prediction import MAX_SEGMENTS
    from battery_simulator.srv import PredictRequest

    def wire(**fields):
        buffer = io.BytesIO()
        PredictRequest(**fields).serialize(buffer)
        return buffer.getvalue()
    raw = service.RawPredictRequest().deserialize(wire(duration_s=[60.0, 30.5], power_w=[1.0, 2.0],
                                                       charge_to_percentage=80.0))
    assert raw.raw_arrays == (array('d', [60.0, 30.5]).tobytes(), b'', array('d', [1.0, 2.0]).tobytes(), b'', b'')
    assert raw.charge_to_percentage == 80.0 and raw.too_many is None
    big = service.RawPredictRequest().deserialize(wire(duration_s=[1.0] * 10, turn_radps=[0.0] * (MAX_SEGMENTS + 1)))
    assert big.too_many == ('turn_radps', MAX_SEGMENTS + 1) and big.raw_arrays is None
    response = service.answer('robot0', big, pickle.dumps(BatteryModel(PACK, 0.5)), 0.0)
    assert not response.success and math.isnan(response.end_percentage)
    assert response.message == ('turn_radps has 100001 entries, which is invalid: a plan has at most 100000 '
                                'segments (a day at one-second resolution)')
    genpy = pytest.importorskip('genpy')
    with pytest.raises(genpy.DeserializationError):
        service.RawPredictRequest().deserialize(wire(duration_s=[1.0, 2.0])[:-12])
