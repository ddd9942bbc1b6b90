"""The rules both front ends' servers share, written once in core/ (issue 41): the one battery factory, the
server's log lines and progress rule (core/server_log.py), the one save throttle and load() shape
(core/state_file.py), and one refusal text for a setting, at start-up or at run time."""
import ast
from pathlib import Path

import pytest

from battery_simulator.core.battery import Battery, BatteryError, GoalEnd, new_battery, parse_mode
from battery_simulator.core.battery_states import Mode, Status
from battery_simulator.core.config_files import preset
from battery_simulator.core.node_settings import (MODE_ALLOWED, SettingError, check_setting, is_mode_value, refusal,
                                                  setting)
from battery_simulator.core.server_log import LOG_PERIOD_S, PROGRESS_PERIOD_S, ServerLog, charger_reply
from battery_simulator.core.state_file import SAVE_EVERY_PERCENT, SAVE_EVERY_S, SaveThrottle, StateFileKeeper

PACKAGE = Path(__file__).resolve().parents[2] / 'src' / 'battery_simulator'
SETTINGS = dict(initial_percentage=80.0, time_scale=50.0, max_time_jump=100.0)


class Lines:
    """A BatteryLog stand-in: every line written, with its level (throttles pass, as the first call does)."""

    def __init__(self):
        self.lines = []

    def _add(level):
        def write(self, *args):
            if isinstance(args[0], float):   # a *_throttle call: (period, text, *args)
                args = args[1:]
            self.lines.append((level, args[0] % args[1:] if len(args) > 1 else args[0]))
        return write

    info = progress = info_throttle = transition = _add('info')
    warn = warn_throttle = _add('warn')
    error = error_throttle = _add('error')

    def settle(self):
        pass


# -- one factory -------------------------------------------------------------------------------------------

def test_the_factory_builds_a_wall_time_battery_from_the_settings():
    battery = new_battery(preset('lg_hg2_3s1p'), SETTINGS, True, 'charging', Lines())
    assert isinstance(battery, Battery)
    assert not battery.sim_time and battery.time_scale == 50.0 and battery.max_time_jump == 100.0
    assert battery.initial_percentage == pytest.approx(80.0) and battery.mode is Mode.CHARGE
    assert battery.mode_name == 'charging'


def test_the_factory_runs_on_the_ros_clock_it_is_given_and_defaults_the_rest():
    now = [12.5]
    battery = new_battery(preset('lg_hg2_3s1p'), dict(initial_percentage=30.0), False, '/MyRobot/BatteryStatus',
                          Lines(), ros_clock=lambda: now[0])
    assert battery.sim_time and battery.time_scale == setting('time_scale').default
    assert battery.max_time_jump == setting('max_time_jump').default and battery.mode is Mode.DISCHARGE


# -- the server's lines ------------------------------------------------------------------------------------

class Snapshot:
    def __init__(self, percentage, status=Status.DISCHARGING, current_a=-1.5):
        self.percentage, self.voltage_v, self.current_a, self.status = percentage, 11.62, current_a, status


def test_the_progress_line_comes_once_a_whole_percent_at_most_once_a_period():
    now = [100.0]
    log = Lines()
    lines = ServerLog(log, clock=lambda: now[0])
    lines.progress(Snapshot(57.9))
    lines.progress(Snapshot(57.1))                        # the same whole percent
    now[0] += PROGRESS_PERIOD_S / 2
    lines.progress(Snapshot(56.9))                        # a new percent, but too soon
    now[0] += PROGRESS_PERIOD_S
    lines.progress(Snapshot(56.5))
    assert log.lines == [('info', 'Discharging... 57 % (11.62 V, -1.50 A)'),
                         ('info', 'Discharging... 56 % (11.62 V, -1.50 A)')]


def test_a_new_status_is_said_at_once_and_empty_says_how_to_charge():
    now = [100.0]
    log = Lines()
    lines = ServerLog(log, clock=lambda: now[0])
    lines.progress(Snapshot(0.4))
    now[0] += 0.1
    lines.progress(Snapshot(0.0, Status.EMPTY, 0.0))          # the same whole percent, too soon: said all the same
    now[0] += 0.1
    lines.progress(Snapshot(0.0, Status.CHARGING, 1.5))
    assert log.lines == [
        ('info', 'Discharging... 0 % (11.62 V, -1.50 A)'),
        ('info', 'Empty... 0 % (11.62 V, +0.00 A): cut off; charge it with a charge goal (battery_sim_client 1) or '
                 'set_charging'),
        ('info', 'Charging... 0 % (11.62 V, +1.50 A)')]


def test_the_goal_and_charger_lines_are_one_text_for_both_front_ends():
    log = Lines()
    lines = ServerLog(log)
    lines.goal_started(Mode.CHARGE, 24.66)
    lines.goal_ended(GoalEnd(GoalEnd.SUCCEEDED, 'Full'))
    lines.goal_ended(GoalEnd(GoalEnd.ABORTED, 'the mode turned to discharge'))
    lines.charger(True, 'charger contact')
    assert log.lines == [('info', 'goal: charge from 24.7 %'), ('info', 'goal ended: Full'),
                         ('warn', 'goal ended: the mode turned to discharge'),
                         ('info', 'charger contact: charger connected')]
    assert charger_reply(False) == 'charger disconnected' and LOG_PERIOD_S == 1.0


@pytest.mark.parametrize('front_end', ['ros1', 'ros2'])
def test_no_front_end_writes_a_server_line_or_period_of_its_own(front_end):
    server = PACKAGE / front_end / 'action_server.py'
    text = server.read_text()
    for own in ("'goal: %s from", "'goal ended", "charger connected'", 'LOG_PERIOD_S =', 'JUMP_LOG_PERIOD_S =',
                "'%s... %d %%"):
        assert own not in text, '%s has its own %s' % (server, own)


# -- one save throttle, one load() ----------------------------------------------------------------------------

def test_the_save_throttle_saves_the_first_then_on_a_move_or_after_a_while():
    now = [0.0]
    throttle = SaveThrottle(clock=lambda: now[0])
    state = {'state_of_charge': 0.5}
    assert throttle.due(state)
    throttle.wrote(state)
    assert not throttle.due({'state_of_charge': 0.5 + SAVE_EVERY_PERCENT / 200.0})
    assert throttle.due({'state_of_charge': 0.5 + SAVE_EVERY_PERCENT / 100.0})
    now[0] += SAVE_EVERY_S
    assert throttle.due(state)


def test_a_keepers_load_is_the_state_and_where_says_where(tmp_path):
    path = str(tmp_path / 'state.json')
    keeper = StateFileKeeper(path)
    assert keeper.load() is None
    keeper.save_now({'state_of_charge': 0.25})
    assert keeper.load() == {'state_of_charge': 0.25} and keeper.where == path


# -- one refusal text ---------------------------------------------------------------------------------------

def test_time_scale_at_run_time_is_refused_with_the_start_up_text():
    battery = Battery(preset('lg_hg2_3s1p'), time_scale=22.0)
    with pytest.raises(SettingError) as at_start:
        check_setting(setting('time_scale'), -1)
    with pytest.raises(BatteryError) as at_run_time:
        battery.set_live('time_scale', -1)
    assert str(at_run_time.value) == str(at_start.value) + '; keeping 22'
    assert str(at_start.value).startswith('parameter time_scale = -1 is invalid: must be a number in (0, 10000]')


@pytest.mark.parametrize('value, valid', [(True, True), (False, True), (1, True), (0, True), (1.0, True),
                                          (2, False), ('1', False), (None, False), ([1], False)])
def test_the_modes_values_are_one_rule(value, valid):
    assert is_mode_value(value) is valid
    assert (parse_mode(value) is not None) is (valid or value is None)   # unset holds the mode (ROS 1)
    assert setting('charging').check(value) is valid


def test_a_bad_mode_value_is_logged_with_the_one_text():
    log = Lines()
    battery = Battery(preset('lg_hg2_3s1p'), mode_name='/MyRobot/BatteryStatus', log=log)
    battery.follow_mode_value(2)
    assert log.lines[-1][1].startswith(refusal('/MyRobot/BatteryStatus', 2, 'must be ' + MODE_ALLOWED))


def formatted_refusals(path):
    """String constants of ``path`` that spell a refusal's ``= %r is invalid`` themselves."""
    return [node.value for node in ast.walk(ast.parse(path.read_text())) if isinstance(node, ast.Constant)
            and isinstance(node.value, str) and '= %' in node.value and 'is invalid' in node.value]


@pytest.mark.parametrize('folder', ['ros1', 'ros2', 'web', 'robot'])
def test_the_front_ends_spell_no_refusal_of_their_own(folder):
    """'parameter %s = %r is invalid' is core/parameter_rules.py refusal(); the fleet hosts are another
    session's today (issue 41 leaves them to it)."""
    for path in sorted((PACKAGE / folder).glob('*.py')):
        if path.name == 'fleet_host.py':
            continue
        assert formatted_refusals(path) == [], '%s spells its own refusal' % path
