"""Predictions in worker processes, so that no prediction slows the batteries of the process that asks.

A prediction is CPU-bound Python. Run in a service thread of a fleet host, it
holds the GIL and starves the host's update worker: 8 threads asking robot0
for one-hour plans delayed robot1's contact -> CHARGING from 4 ms to about
1 s. PredictionPool runs them in worker processes instead (no rospy, nothing
of ROS imported there):

  - A worker is a fresh interpreter (``python3 -m
    battery_simulator.core.prediction_worker FD PID``, not a fork of a
    process full of threads) that imports only the core. It gets each job
    over a socket pair: a pickled copy of the model (5 kB), how far it is
    behind, the loads to drop, the plan's arrays (raw little-endian float64
    bytes, or sequences) and the charge level; it answers the Prediction, or
    the refusal's message. It runs at a lower priority (nice +NICE) than the
    batteries.
  - It ends with its parent: at the socket's end of file, and while it
    computes when its parent changes (checked every PARENT_CHECK_S). It runs
    in a session of its own and ignores SIGINT (Ctrl-C to the node's process
    group never reaches it, even while it starts: the parent ends and the
    worker follows it); SIGTERM ends it at once, without a traceback.
  - The first worker starts with the pool; a second one (up to ``workers``)
    starts when a job waits while every worker is busy. A robot has at most
    one job in the workers at a time and the robots take turns, so a flood
    of one robot's predictions leaves a worker to the others.
  - A worker that dies, or takes longer than ``job_timeout_s``, is ended and
    started again for the next job; the job it held is answered with a
    message (WorkerFailed).
  - Waiting is bounded: a key (a robot) has at most ``per_key`` jobs waiting
    or running, all keys together ``max_waiting`` jobs and
    ``max_queued_segments`` segments; a job beyond waits at most ``admit_s``
    for room, then is refused with Busy ("busy, try again"), so that a
    client asking again at once does not spin. A caller waits at most
    ``timeout_s`` in all.

The process's one pool is ``shared_pool()``.
"""
import math
import os
import pickle
import signal
import socket
import subprocess
import sys
import threading
import time
from array import array
from collections import OrderedDict, deque
from multiprocessing.connection import Connection

from battery_simulator.core.prediction import PredictionError, plan_from_arrays, predict

#: a worker's niceness above its parent's: the batteries come first when the cores are busy
NICE = 5
#: a worker checks this often (s) that its parent lives, while it computes
PARENT_CHECK_S = 0.2
#: worker processes at most (the second starts when a job waits while the first is busy)
WORKERS = 2
#: jobs one key (a robot) may have waiting or running
PER_KEY = 4
#: jobs all keys together may have waiting or running
MAX_WAITING = 256
#: segments all waiting jobs together may have (about 6 s of a worker's time; 40 MB of plans)
MAX_QUEUED_SEGMENTS = 1_000_000
#: a job beyond those bounds waits this long (s) for room before it is refused
ADMIT_S = 1.0
#: a caller waits this long (s) for its answer at most (then busy): every request answered within 10 s
TIMEOUT_S = 7.0
#: a job running longer (s) ends its worker (the longest allowed plan takes about 2 s)
JOB_TIMEOUT_S = 30.0
#: a worker that ended is started again at most this often (s): a job that kills it cannot make a loop
RESTART_GAP_S = 1.0
#: a worker still there this long (s) after SIGTERM gets SIGKILL
STOP_WAIT_S = 0.5


class Busy(Exception):
    """The pool refused a job or gave up waiting for it; the caller may try again later."""


class WorkerFailed(Exception):
    """The worker died or was ended while it held the job, or the job raised an unexpected error."""


class PredictionPool:
    """Jobs from many keys (robots), answered by up to ``workers`` worker processes.

    Lock order: only self._cond, never held while talking to a worker.
    """

    def __init__(self, workers=WORKERS, per_key=PER_KEY, max_waiting=MAX_WAITING,
                 max_queued_segments=MAX_QUEUED_SEGMENTS, admit_s=ADMIT_S, job_timeout_s=JOB_TIMEOUT_S,
                 restart_gap_s=RESTART_GAP_S):
        self._per_key, self._max_waiting, self._max_segments = per_key, max_waiting, max_queued_segments
        self._admit_s = admit_s
        self.job_timeout_s, self.restart_gap_s = job_timeout_s, restart_gap_s
        self._cond = threading.Condition()
        self._queues = OrderedDict()   # key -> deque of _Job waiting (round robin: the key served last goes last)
        self._running = set()          # keys with a job in a worker
        self._jobs = {}                # key -> its jobs waiting or running
        self._waiting = 0              # jobs waiting or running
        self._segments = 0             # their segments
        self._idle = 0                 # lanes waiting for a job
        self._stopping = False
        self._lanes = [_Lane(self, k) for k in range(workers)]
        self._started = 0              # lanes with a thread

    def start(self):
        """Start the first worker (its interpreter starts in the background) and its thread."""
        with self._cond:
            if self._started or self._stopping:
                return
            self._started = 1
        self._lanes[0].start()

    def stop(self):
        """End every worker (within about STOP_WAIT_S) and refuse what waits; idempotent."""
        with self._cond:
            self._stopping = True
            for queue in self._queues.values():
                for job in queue:
                    job.finish(('busy', 'busy, try again: the node is shutting down'))
            self._queues.clear()
            self._cond.notify_all()
        for lane in self._lanes:
            lane.end_worker()

    def worker_pids(self):
        """The process ids of the workers running now."""
        return [pid for pid in (lane.pid() for lane in self._lanes) if pid is not None]

    def jobs(self, key=None):
        """How many jobs (of ``key``, or of all keys) are waiting or running, and the keys running."""
        with self._cond:
            return (self._waiting if key is None else self._jobs.get(key, 0)), sorted(self._running)

    def run(self, key, job, segments, timeout_s=TIMEOUT_S):
        """The Prediction of ``job`` (see _answer) for ``key``, which has ``segments`` segments.

        Raises PredictionError (a bad plan: its message), Busy (refused, or no answer within
        ``timeout_s``: try again) or WorkerFailed.
        """
        entry = _Job(key, job, segments)
        deadline = time.monotonic() + timeout_s
        with self._cond:
            admit_until = min(time.monotonic() + self._admit_s, deadline)
            while True:   # wait (a while) for room rather than answer busy at once to a client that asks again
                refusal = self._refusal(key, segments)
                left_s = admit_until - time.monotonic()
                if refusal is None:
                    break
                if self._stopping or left_s <= 0.0:
                    raise Busy(refusal)
                self._cond.wait(left_s)
            self._queues.setdefault(key, deque()).append(entry)
            self._jobs[key] = self._jobs.get(key, 0) + 1
            self._waiting += 1
            self._segments += segments
            self._cond.notify_all()
            self._add_lane_if_needed()
        if not entry.done.wait(max(0.0, deadline - time.monotonic())):
            with self._cond:
                if not entry.done.is_set():   # still waiting (then forgotten) or running (its reply dropped)
                    queue = self._queues.get(key)
                    if queue is not None and entry in queue:
                        queue.remove(entry)
                        if not queue:
                            del self._queues[key]
                        self._forget(entry)
                    raise Busy('busy, try again: no answer within %g s (%d predictions waiting or running in '
                               'this process)' % (timeout_s, self._waiting))
        kind, value = entry.reply
        if kind == 'ok':
            return value
        if kind == 'refused':
            raise PredictionError(value)
        if kind == 'busy':
            raise Busy(value)
        raise WorkerFailed(value)

    def _refusal(self, key, segments):
        """Why a job of ``segments`` for ``key`` cannot wait now, or None (self._cond held)."""
        if self._stopping:
            return 'busy, try again: the node is shutting down'
        if self._jobs.get(key, 0) >= self._per_key:
            return ('busy, try again: %d predictions of %s are waiting or running (at most %d)'
                    % (self._jobs[key], key, self._per_key))
        if self._waiting >= self._max_waiting:
            return ('busy, try again: %d predictions are waiting or running in this process (at most %d)'
                    % (self._waiting, self._max_waiting))
        if self._segments + segments > self._max_segments:
            return ('busy, try again: the predictions waiting in this process have %d segments (at most %d '
                    'with this one\'s %d)' % (self._segments, self._max_segments, segments))
        return None

    def _add_lane_if_needed(self):
        """Start another worker when a job can run now but no lane is idle (self._cond held)."""
        if self._idle == 0 and self._started < len(self._lanes) and self._next_key() is not None:
            lane = self._lanes[self._started]
            self._started += 1
            lane.start(spawn=False)   # its thread starts the worker with its first job

    def _next_key(self):
        """The first key in turn with a job waiting and none running, or None (self._cond held)."""
        return next((key for key, queue in self._queues.items() if queue and key not in self._running), None)

    def take(self):
        """The next job for a lane (waits), or None when stopping."""
        with self._cond:
            self._idle += 1
            try:
                while True:
                    if self._stopping:
                        return None
                    key = self._next_key()
                    if key is not None:
                        break
                    self._cond.wait()
            finally:
                self._idle -= 1
            entry = self._queues[key].popleft()
            self._queues.move_to_end(key)
            if not self._queues[key]:
                del self._queues[key]
            self._running.add(key)
            return entry

    def done(self, entry, reply):
        """A lane's answer to ``entry``."""
        with self._cond:
            self._running.discard(entry.key)
            self._forget(entry)
            entry.finish(reply)
            self._cond.notify_all()

    def _forget(self, entry):
        self._jobs[entry.key] -= 1
        if not self._jobs[entry.key]:
            del self._jobs[entry.key]
        self._waiting -= 1
        self._segments -= entry.segments

    @property
    def stopping(self):
        return self._stopping


class _Job:
    """One caller's job, and its reply once done."""

    def __init__(self, key, job, segments):
        self.key, self.job, self.segments = key, job, segments
        self.done = threading.Event()
        self.reply = None

    def finish(self, reply):
        self.reply = reply
        self.done.set()


class _Lane:
    """One worker process and the thread of the pool that feeds it, one job at a time."""

    def __init__(self, pool, number):
        self._pool, self._number = pool, number
        self._lock = threading.Lock()   # the process and its connection
        self._process = None
        self._conn = None
        self._started_at = -math.inf

    def start(self, spawn=True):
        if spawn:
            self._spawn()
        threading.Thread(target=self._run, name='prediction_lane_%d' % self._number, daemon=True).start()

    def pid(self):
        with self._lock:
            process = self._process
        return process.pid if process is not None and process.poll() is None else None

    def _run(self):
        while True:
            entry = self._pool.take()
            if entry is None:
                return
            try:
                reply = self._ask(entry.job)
            except Exception as error:   # a defect here must not leave the callers waiting
                reply = ('failed', 'the prediction failed: %s: %s' % (type(error).__name__, error))
            self._pool.done(entry, reply)

    def _ask(self, job):
        """The worker's reply to ``job``: starts the worker if it is not running."""
        if self.pid() is None:
            time.sleep(max(0.0, self._started_at + self._pool.restart_gap_s - time.monotonic()))
            self._spawn()
        with self._lock:
            process, conn = self._process, self._conn
        if process is None:
            return ('busy', 'busy, try again: the node is shutting down')
        deadline = time.monotonic() + self._pool.job_timeout_s
        try:
            conn.send(job)
            while not conn.poll(0.1):
                if self._pool.stopping:
                    return ('busy', 'busy, try again: the node is shutting down')
                if process.poll() is not None:
                    raise EOFError
                if time.monotonic() > deadline:
                    self.end_worker()
                    return ('failed', 'the prediction took longer than %g s: its worker was ended and starts '
                            'again for the next one' % self._pool.job_timeout_s)
            return conn.recv()
        except (EOFError, OSError, TypeError):   # TypeError: the connection was closed meanwhile (stop)
            if self._pool.stopping:
                return ('busy', 'busy, try again: the node is shutting down')
            code = self.end_worker(grace_s=STOP_WAIT_S)   # it is ending: its own exit code
            return ('failed', 'the prediction worker ended (%s) during this prediction; it starts again for the '
                    'next one' % _exit_text(code))

    def _spawn(self):
        """Start a worker process."""
        with self._lock:
            if self._pool.stopping:
                return
            parent_end, child_end = socket.socketpair()
            for end in (parent_end, child_end):   # blocking, whatever socket.setdefaulttimeout (rospy) says
                end.setblocking(True)
            with child_end:
                env = dict(os.environ, PYTHONPATH=os.pathsep.join(path for path in sys.path if path))
                self._process = subprocess.Popen(
                    [sys.executable, '-m', __name__, str(child_end.fileno()), str(os.getpid())],
                    pass_fds=(child_end.fileno(),), stdin=subprocess.DEVNULL, env=env,
                    start_new_session=True)   # Ctrl-C to the node's group never reaches it, even while it
                    # imports (it follows its parent: end of file on its socket, or the parent gone)
            self._conn = Connection(parent_end.detach())
            self._started_at = time.monotonic()

    def end_worker(self, grace_s=0.0):
        """End the worker: its socket closed, ``grace_s`` to end by itself, then SIGTERM (it holds nothing
        worth finishing), and SIGKILL if it lingers; its exit code, or None if there was none."""
        with self._lock:
            process, conn = self._process, self._conn
            self._process = self._conn = None
        if conn is not None:
            conn.close()
        if process is None:
            return None
        try:
            process.wait(grace_s)
        except subprocess.TimeoutExpired:
            process.terminate()
        try:
            return process.wait(STOP_WAIT_S)
        except subprocess.TimeoutExpired:
            process.kill()
            return process.wait()


def _exit_text(code):
    if code is None:
        return 'its connection closed'
    if code < 0:
        try:
            return 'signal %s' % signal.Signals(-code).name
        except ValueError:
            return 'signal %d' % -code
    return 'exit code %d' % code


_shared = None
_shared_lock = threading.Lock()


def shared_pool():
    """The process's one PredictionPool, started at the first call."""
    global _shared
    with _shared_lock:
        if _shared is None:
            _shared = PredictionPool()
            _shared.start()
        return _shared


def stop_shared_pool():
    """End the process's pool's workers (at shutdown)."""
    with _shared_lock:
        pool = _shared
    if pool is not None:
        pool.stop()


# -- the worker process ---------------------------------------------------------------

def job(model_pickle, behind_s, dropped_loads, arrays, charge_to_percentage):
    """A job for the worker: the model as pickle.dumps gave it, stepped ``behind_s`` s to now at its
    loads, then without the named loads ``dropped_loads``; the plan's five arrays (Predict.srv's order)."""
    return (model_pickle, behind_s, tuple(dropped_loads), tuple(arrays), charge_to_percentage)


def _floats(values):
    """An array of Predict.srv's: raw little-endian float64 bytes as an array, anything else as it is."""
    if not isinstance(values, (bytes, bytearray, memoryview)):
        return values
    floats = array('d')
    floats.frombytes(values)
    if sys.byteorder == 'big':
        floats.byteswap()
    return floats


def _answer(job_):
    """('ok', Prediction), ('refused', message) for a bad plan, or ('failed', message) for a defect."""
    model_pickle, behind_s, dropped_loads, arrays, charge_to_percentage = job_
    try:
        segments = plan_from_arrays(*(_floats(values) for values in arrays))
        model = pickle.loads(model_pickle)
        model.step(behind_s)
        for name in dropped_loads:
            model.set_extra_load(name)
        return ('ok', predict(model, segments, charge_to_percentage))
    except PredictionError as error:
        return ('refused', str(error))
    except Exception as error:   # a defect: said in the reply (and on stderr), and the worker serves on
        import traceback
        traceback.print_exc()
        return ('failed', 'the prediction failed: %s: %s' % (type(error).__name__, error))


def _follow_parent(parent_pid):
    """End this process when its parent has ended (its parent process id changes)."""
    while os.getppid() == parent_pid:
        time.sleep(PARENT_CHECK_S)
    os._exit(0)


def serve(fd, parent_pid):
    """The worker's loop: a job in, its answer out, until the end of file or the parent's end."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    # a node holds these while it starts (ros/startup.signals_held), and a child inherits the mask
    signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT, signal.SIGTERM})
    os.set_blocking(fd, True)
    try:
        os.nice(NICE)
    except OSError:
        pass
    threading.Thread(target=_follow_parent, args=(parent_pid,), daemon=True).start()
    conn = Connection(fd)
    while True:
        try:
            received = conn.recv()
        except (EOFError, OSError):
            return
        try:
            conn.send(_answer(received))
        except OSError:
            return


if __name__ == '__main__':
    serve(int(sys.argv[1]), int(sys.argv[2]))
