"""rclpy's EventsExecutor for a fleet host, with what Kilted's needs around it: its timer warnings kept off stdout
and ``spin_until_future_complete`` given a timeout (without one it runs no callback). A ROS 2 extra: ROS 1's
rospy has no executor."""
import sys

from rclpy.executors import SingleThreadedExecutor
try:
    from rclpy.experimental import EventsExecutor
except ImportError:   # rclpy before Jazzy
    EventsExecutor = None


def many_entities_executor():
    """rclpy's EventsExecutor (C++, event driven) where rclpy has it: the SingleThreadedExecutor rebuilds its wait set
    over every entity at each wake-up (27 a robot; 171 ms a wake-up at 250 robots), which took a fleet of 1000 to a
    quarter of a core doing nothing and held a stop signal for seconds. Measured with 300 robots' endpoints and a 1 Hz
    timer: 23 % of a core spinning with the SingleThreadedExecutor, 1 % with the EventsExecutor. For every process
    with many entities: the fleet host, and battery_demo's eight nodes (its paced clock)."""
    if EventsExecutor is None:
        return SingleThreadedExecutor()
    sys.stdout = _WithoutTimerWarnings(sys.stdout)
    return _EventsExecutor(EventsExecutor())


def is_events_executor(executor):
    """Whether ``executor`` is rclpy's EventsExecutor (``rclpy.experimental.EventsExecutor`` is a factory: the
    instance's type is its C++ class), which takes timers and services but no guard conditions."""
    return EventsExecutor is not None and type(executor).__name__ == 'EventsExecutor'


#: what Kilted's EventsExecutor prints (Python's print, on stdout) for every timer of one clock past its 8th: each
#: robot's action server holds a timer (rcl_action's goal expiry) on the host node's clock, so 1000 robots would
#: print 2000 lines that say nothing to a user (it manages them in one ordered map: no cost per wake-up)
TIMER_WARNINGS = ('Warning, the number of timers associated with this clock is large.',
                  'Management of this number of timers may be inefficient.')


class _WithoutTimerWarnings:
    """sys.stdout without TIMER_WARNINGS (and the line ends printed after them)."""

    def __init__(self, stream):
        self._stream = stream
        self._dropped = False

    def __getattr__(self, name):
        return getattr(self._stream, name)

    def write(self, text):
        if text in TIMER_WARNINGS or (self._dropped and text == '\n'):
            self._dropped = text != '\n'
            return len(text)
        self._dropped = False
        return self._stream.write(text)


class _EventsExecutor:
    """The EventsExecutor as ``run`` uses an executor. Kilted's ``spin_until_future_complete(future)`` without a
    timeout runs no callback at all (no timer fires, a Future set from another thread never ends it: measured);
    with one it works, so it is given one, again and again until the future is done."""

    SPIN_SLICE_S = 0.1   # how late a stop signal may be seen; a wake-up of the EventsExecutor costs next to nothing

    def __init__(self, executor):
        self._executor = executor

    def __getattr__(self, name):
        return getattr(self._executor, name)

    def spin_until_future_complete(self, future, timeout_sec=None):
        if timeout_sec is not None:
            return self._executor.spin_until_future_complete(future, timeout_sec=timeout_sec)
        while not future.done():
            self._executor.spin_until_future_complete(future, timeout_sec=self.SPIN_SLICE_S)
