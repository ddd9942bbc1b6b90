"""The battery server's log lines, for any ROS (no ROS import): their texts, how often each may repeat, and the
progress rule. Both front ends' action_server.py write a battery's lines through ServerLog, so a goal, a charger
change or a level says the same on ROS 1 and ROS 2."""
import time

from battery_simulator.core.battery import INVALID_LOG_PERIOD_S, GoalEnd
from battery_simulator.core.battery_states import Status

#: lines an input can repeat at any rate (contact flapping, a flood of goals) at most this often
LOG_PERIOD_S = 1.0
#: a clock that jumps back and forth (two /clock publishers) warns this often
JUMP_LOG_PERIOD_S = 10.0
#: the progress line: one per whole percent, at most this often
PROGRESS_PERIOD_S = 1.0
#: why a goal ends when the server stops (ROS 1 preempts it, ROS 2 aborts it: the text is the same)
SHUTDOWN_TEXT = 'server shutting down'
#: the progress line at Empty says how to charge (the action's charge goal, the charger's service)
EMPTY_HINT = ': cut off; charge it with a charge goal (battery_sim_client 1) or set_charging'


def charger_reply(connected):
    """set_charging's reply text."""
    return 'charger %s' % ('connected' if connected else 'disconnected')


class ServerLog:
    """One battery server's lines on ``log`` (a core/battery_log.py BatteryLog: throttled per robot)."""

    def __init__(self, log, clock=time.monotonic):
        self.log = log
        self._clock = clock
        self._progress = (None, -PROGRESS_PERIOD_S, None)   # (whole percent, time, status) of the last progress line

    def goal_started(self, mode, percentage):
        self.log.info_throttle(LOG_PERIOD_S, 'goal: %s from %.1f %%', mode.value, percentage)

    def goal_ended(self, end):
        """An aborted goal is a warning; a reached or preempted one is information."""
        write = self.log.warn_throttle if end.outcome == GoalEnd.ABORTED else self.log.info_throttle
        write(LOG_PERIOD_S, 'goal ended: %s', end.text)

    def goal_rejected(self, reason):
        self.log.warn_throttle(LOG_PERIOD_S, 'goal rejected: %s', reason)

    def charger(self, connected, source):
        """Every change said, none throttled; a bouncing contact counted on one line (core/battery_log.py's
        transition, said by ``settle``)."""
        self.log.transition('%s: charger connected' if connected else '%s: charger disconnected', source)

    def settle(self):
        """At every update: the bounces of a contact that has stood still since (core/battery_log.py)."""
        self.log.settle()

    def time_jump(self, update, max_jump_s, clock_publishers):
        """An update's clock jump (core/battery.py Update.time_jump), naming the /clock publishers."""
        self.log.warn_throttle(JUMP_LOG_PERIOD_S, '%s', update.time_jump_warning(max_jump_s, clock_publishers))

    def input_error(self, text, *args):
        """A bad input (a message of another type): as often as the battery says a command it refuses."""
        self.log.error_throttle(INVALID_LOG_PERIOD_S, text, *args)

    def progress(self, snapshot):
        """``Discharging... 57 % (11.62 V, -1.50 A)``: when the whole percent changed, at most every
        PROGRESS_PERIOD_S, and at once when the status changed (Empty says how to charge it: a battery that went
        silent at 0 % looked hung); a fleet host's BatteryLog writes no progress."""
        whole, status = int(snapshot.percentage), snapshot.status
        logged_percent, logged_at, logged_status = self._progress
        now = self._clock()
        if status is not logged_status or (whole != logged_percent and now - logged_at >= PROGRESS_PERIOD_S):
            self._progress = (whole, now, status)
            self.log.progress('%s... %d %% (%.2f V, %+.2f A)%s', status.value.capitalize(), whole,
                              snapshot.voltage_v, snapshot.current_a, EMPTY_HINT if status is Status.EMPTY else '')
