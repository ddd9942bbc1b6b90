"""ROS 2 predict under many requests at once, without processes (issue 40 item 6; the ROS 1 twin is
test/ros1/test_prediction_flood.py; the ROS 2 flood against a running battery_sim is in test_hardening_timing.py).

rmw_fastrtps delivers every response of a service to every client of that service, and a client's response
queue keeps the last 10 (the default): 40 clients asking at once lost 1-19 of their answers when the refusals
went out in one burst, although the server sent them all. ros2/prediction_service.py's AnswerHandout spaces one
service's answers (ANSWER_GAP_S) and still answers each within ANSWER_BY_S of its request; an unexpected error
in a request's thread is answered, not left waiting. Here with a node that records its timer and guard
condition, and a clock the test moves."""
import threading
import time

import pytest
from rclpy.task import Future

from battery_simulator.ros2 import prediction_service
from battery_simulator.ros2.prediction_service import ANSWER_BY_S, ANSWER_GAP_S, ANSWER_POLL_S, AnswerHandout
from battery_simulator.srv import Predict


class FakeTimer:
    def __init__(self, callback):
        self.callback, self.canceled = callback, False

    def cancel(self):
        self.canceled = True

    def reset(self):
        self.canceled = False

    def is_canceled(self):
        return self.canceled


class FakeGuard:
    def __init__(self, callback):
        self.callback, self.triggers = callback, 0

    def trigger(self):
        self.triggers += 1


class FakeNode:
    """What AnswerHandout asks of a node: a timer and a guard condition, kept to be fired by the test."""

    executor = None

    def __init__(self):
        self.timers, self.guards = [], []

    def create_timer(self, period_s, callback, callback_group=None, clock=None):
        assert period_s == ANSWER_POLL_S
        self.timers.append(FakeTimer(callback))
        return self.timers[-1]

    def create_guard_condition(self, callback, callback_group=None):
        self.guards.append(FakeGuard(callback))
        return self.guards[-1]


class Clock:
    def __init__(self):
        self.now = 100.0

    def __call__(self):
        return self.now


def handout(polled=False):
    node, clock = FakeNode(), Clock()
    return AnswerHandout(node, None, polled, clock=clock), node, clock


def ask(given, service, clock, count):
    """``count`` requests of ``service`` asked now and answered at once by the workers: their futures."""
    futures = []
    for index in range(count):
        asked_at = given.asked()
        futures.append(Future())
        given.put(service, asked_at, futures[-1], ('refused', 'busy, try again %d' % index))
    return futures


def run_ticks(given, node, clock, futures, until_s):
    """Fire the timer every ANSWER_POLL_S while it runs, up to ``until_s`` from now: when each future was done."""
    done_at = {}
    end = clock.now + until_s
    while clock.now <= end:
        for index, future in enumerate(futures):
            if future.done() and index not in done_at:
                done_at[index] = clock.now
        if node.timers[0].is_canceled():
            break
        clock.now += ANSWER_POLL_S
        node.timers[0].callback()
    for index, future in enumerate(futures):
        if future.done() and index not in done_at:
            done_at[index] = clock.now
    return done_at


def test_answers_of_one_service_put_at_once_go_at_least_the_gap_apart():
    """30 answers of one service put at once (the refusals of a flood): one at once, the others one a gap apart
    (before: all 30 in one burst, and a client keeping the last 10 lost its own)."""
    given, node, clock = handout()
    futures = ask(given, 'predict', clock, 30)
    assert node.guards[0].triggers == 30
    node.guards[0].callback()
    assert sum(future.done() for future in futures) == 1, 'more than one answer of a service at once'
    assert not node.timers[0].is_canceled(), 'the answers waiting for their turn have no timer'
    done_at = run_ticks(given, node, clock, futures, ANSWER_BY_S)
    assert len(done_at) == 30, '%d of 30 answered' % len(done_at)
    times = sorted(done_at.values())
    gaps = [later - earlier for earlier, later in zip(times, times[1:])]
    assert min(gaps) >= ANSWER_GAP_S - 1e-9, 'answers %g s apart (at least %g)' % (min(gaps), ANSWER_GAP_S)
    assert times[-1] - times[0] <= 29 * (ANSWER_GAP_S + ANSWER_POLL_S) + 1e-9, 'the turns are slower than a tick'
    assert node.timers[0].is_canceled(), 'the timer runs on with nothing to hand out'
    assert [future.result()[1] for future in sorted(futures, key=lambda f: done_at[futures.index(f)])] == \
        ['busy, try again %d' % index for index in range(30)], 'answered out of order'


def test_two_services_do_not_wait_for_each_other():
    """A robot's turn is its own: a fleet's other robot is answered at once."""
    given, node, clock = handout()
    first, second = ask(given, 'robot0/predict', clock, 2), ask(given, 'robot1/predict', clock, 1)
    node.guards[0].callback()
    assert first[0].done() and second[0].done() and not first[1].done()
    clock.now += ANSWER_GAP_S
    node.timers[0].callback()
    assert first[1].done()


def test_a_lone_answer_goes_at_once_and_no_timer_runs_for_it():
    given, node, clock = handout()
    future, = ask(given, 'predict', clock, 1)
    node.guards[0].callback()
    assert future.done() and node.timers[0].is_canceled()
    clock.now += ANSWER_GAP_S   # the next one, a gap later, goes at once too
    later, = ask(given, 'predict', clock, 1)
    node.guards[0].callback()
    assert later.done() and node.timers[0].is_canceled()


def test_no_answer_waits_for_its_turn_past_answer_by_s():
    """More answers at once than a service sends a gap apart within 10 s (the pool's bound, 256): spread over the
    time left, each goes no later than ANSWER_BY_S after its request was taken, and not in one burst at the end."""
    given, node, clock = handout()
    asked_at = clock.now
    futures = ask(given, 'predict', clock, 256)
    node.guards[0].callback()
    done_at = run_ticks(given, node, clock, futures, ANSWER_BY_S + 1.0)
    assert len(done_at) == 256, '%d of 256 answered' % len(done_at)
    latest = max(done_at.values()) - asked_at
    assert latest <= ANSWER_BY_S + ANSWER_POLL_S + 1e-9, 'an answer went %g s after its request' % latest
    at_once = max(list(done_at.values()).count(at) for at in set(done_at.values()))
    assert at_once <= 3, '%d answers in one tick' % at_once
    assert ANSWER_BY_S + 1.0 < 10.0   # room for the request's way to the executor and the answer's back


def test_a_late_tick_counts_the_gap_from_now():
    """A tick that comes late (a busy machine) hands out one answer, not the ones it would have at each tick."""
    given, node, clock = handout()
    futures = ask(given, 'predict', clock, 5)
    node.guards[0].callback()
    clock.now += 5 * ANSWER_GAP_S
    node.timers[0].callback()
    assert sum(future.done() for future in futures) == 2


def test_under_the_events_executor_the_timer_runs_while_a_request_waits():
    """No guard condition (rclpy's EventsExecutor takes none): the timer looks for answers while one waits."""
    given, node, clock = handout(polled=True)
    assert node.guards == [] and node.timers[0].is_canceled()
    asked_at = given.asked()
    assert not node.timers[0].is_canceled(), 'a request waits and nothing looks for its answer'
    future = Future()
    given.put('predict', asked_at, future, ('ok', None))
    clock.now += ANSWER_POLL_S
    node.timers[0].callback()
    assert future.done() and node.timers[0].is_canceled()


class FakeBattery:
    def model_for_prediction_pickled(self):
        return b'', 0.0


def test_an_unexpected_error_in_a_requests_thread_is_answered(monkeypatch):
    """A defect in the path to the workers (not PredictionError, Busy or WorkerFailed) is answered with success
    false and its message (before: it ended the request's thread, and the request was never answered)."""
    def broken(*_args):
        raise RuntimeError('planted defect')
    monkeypatch.setattr(prediction_service, '_in_workers', broken)
    node = FakeNode()
    service = object.__new__(prediction_service.PredictionService)
    service.node, service.battery, service._key, service._predict_group = node, FakeBattery(), 'robot', None
    coroutine = service._predict(Predict.Request(duration_s=[1.0], power_w=[1.0]), Predict.Response())
    coroutine.send(None)   # up to its wait for the answer
    handed = prediction_service.answer_handout(node, None)
    deadline = time.monotonic() + 5.0
    while not node.guards[0].triggers and time.monotonic() < deadline:
        time.sleep(0.01)
    assert node.guards[0].triggers, 'the request\'s thread put no answer within 5 s'
    node.guards[0].callback()
    with pytest.raises(StopIteration) as ended:
        coroutine.send(None)
    response = ended.value.value
    assert response.success is False and 'planted defect' in response.message, response
    assert handed is prediction_service.answer_handout(node, None)
    assert not [thread for thread in threading.enumerate() if thread.name == 'predict' and thread.is_alive()]
