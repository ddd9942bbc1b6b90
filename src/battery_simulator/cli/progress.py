"""The client's progress line, ROS-free (battery_sim_client on ROS 1 and ROS 2 draw the same)."""
from battery_simulator.core.status_codes import SupplyStatus

SUPPLY_STATUS = {SupplyStatus.CHARGING: 'charging', SupplyStatus.DISCHARGING: 'discharging',
                 SupplyStatus.FULL: 'full', SupplyStatus.NOT_CHARGING: 'not charging'}
BAR_WIDTH = 30


def progress_line(percentage, state):
    """'[#####.....]  50.0 %  11.52 V  -1.50 A  discharging' (state: a BatteryState, or None)."""
    filled = int(round(BAR_WIDTH * min(max(percentage, 0.0), 100.0) / 100.0))
    line = '[%s%s] %5.1f %%' % ('#' * filled, '.' * (BAR_WIDTH - filled), percentage)
    if state is not None:
        line += '  %6.2f V  %+6.2f A  %s' % (state.voltage, state.current,
                                             SUPPLY_STATUS.get(state.power_supply_status, 'unknown'))
    return line


class ProgressPrinter:
    """Redraws one progress line (a terminal) or writes a line per percent (a log)."""

    def __init__(self, stream):
        self._stream = stream
        self._last_whole = None
        self.state = None   # the latest BatteryState

    def on_feedback(self, percentage):
        line = progress_line(percentage, self.state)
        whole = int(percentage)
        if self._stream.isatty():
            self._stream.write('\r' + line + '   ')
        elif whole != self._last_whole:
            self._stream.write(line + '\n')
        self._last_whole = whole
        self._stream.flush()
