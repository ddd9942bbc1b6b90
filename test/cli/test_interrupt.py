"""Ctrl-C and SIGTERM end the client's waits through a flag, never by raising inside a lock."""
import os
import signal
import threading

import pytest

from battery_simulator.cli.interrupt import Cancelled, StopRequest, wait_in_wall_time


@pytest.fixture
def stop_on_sigint():
    stop = StopRequest()
    previous = signal.signal(signal.SIGINT, stop.handle)
    yield stop
    signal.signal(signal.SIGINT, previous)


def test_the_wait_result_is_returned():
    assert wait_in_wall_time(lambda: True, 5.0, StopRequest()) is True
    assert wait_in_wall_time(lambda: 0, 5.0, StopRequest()) is False


def test_a_wait_that_never_ends_gives_false_at_the_timeout():
    never = threading.Event()
    assert wait_in_wall_time(never.wait, 0.3, StopRequest()) is False


def test_no_request_lets_check_pass():
    StopRequest().check()


def test_a_request_made_before_the_wait_cancels_it():
    stop = StopRequest()
    stop.handle(signal.SIGTERM, None)
    with pytest.raises(Cancelled):
        wait_in_wall_time(threading.Event().wait, 60.0, stop)


def test_sigint_during_the_wait_cancels_it_and_the_handler_raises_nothing(stop_on_sigint):
    holding = threading.Lock()
    with holding:   # where KeyboardInterrupt used to land: inside threading's own locks
        os.kill(os.getpid(), signal.SIGINT)
    assert stop_on_sigint.requested
    stop_on_sigint.requested = False
    threading.Timer(0.2, os.kill, (os.getpid(), signal.SIGINT)).start()
    with pytest.raises(Cancelled):
        wait_in_wall_time(threading.Event().wait, 60.0, stop_on_sigint)


def test_the_cancel_path_wait_has_no_stop_request_and_runs_to_its_result():
    done = threading.Event()
    threading.Timer(0.1, done.set).start()
    assert wait_in_wall_time(lambda: done.wait(), 60.0) is True
