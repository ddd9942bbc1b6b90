"""A fleet host's robots (core/fleet.py): names, configs, levels, and one line per bad entry; what a host does
every period (Every)."""
import random

import pytest

from battery_simulator.core.fleet import Every, FleetError, RobotSpec, robot_specs, staggered_percentage


def test_a_count_names_the_robots_from_first_and_staggers_their_levels():
    specs = robot_specs(3, prefix='robot', first=4, config='a.yaml')
    assert specs == [RobotSpec('robot4', 'a.yaml', 80.0, False), RobotSpec('robot5', 'a.yaml', 75.0, False),
                     RobotSpec('robot6', 'a.yaml', 70.0, False)]


def test_the_staggered_levels_wrap_at_20_percent_as_fleet_launch_did():
    assert [staggered_percentage(k) for k in (0, 1, 16, 17, 18)] == [100.0, 95.0, 20.0, 100.0, 95.0]


def test_a_fleet_wide_level_and_mode_apply_to_every_counted_robot():
    assert {(s.initial_percentage, s.charging) for s in robot_specs(5, initial_percentage=35.0, charging=True)} \
        == {(35.0, True)}


def test_the_list_form_takes_each_robots_own_keys_and_the_hosts_defaults_for_the_rest():
    specs = robot_specs([{'name': 'scout', 'initial_percentage': 35}, {'name': 'hauler', 'config': 'h.yaml',
                                                                       'charging': True}],
                        config='default.yaml', initial_percentage=None)
    assert specs == [RobotSpec('scout', 'default.yaml', 35.0, False), RobotSpec('hauler', 'h.yaml', 100.0, True)]


@pytest.mark.parametrize('robots, message', [
    (0, '~robots = 0 is invalid: must be a count in [1, 10000] or a list of robots'),
    ([], '~robots = [] is invalid'),
    ('five', "~robots = 'five' is invalid"),
    ([{'name': 'a'}, {'name': 'a'}], 'robot a: name is invalid: another robot has it already'),
    ([{'name': '1st'}], "~robots[0] name = '1st' is invalid: must start with a letter"),
    ([{'name': 'a/b'}], "~robots[0] name = 'a/b' is invalid"),
    ([{'config': 'x.yaml'}], '~robots[0] name = None is invalid'),
    (['robot0'], "~robots[0] = 'robot0' is invalid: must be a mapping with at least a name"),
    ([{'name': 'a', 'initial_percentage': 120}], 'robot a: initial_percentage = 120 is invalid: must be a number '
                                                 'in [0, 100]'),
    ([{'name': 'a', 'initial_percentage': float('nan')}], 'robot a: initial_percentage = nan is invalid'),
    ([{'name': 'a', 'charging': 'maybe'}], "robot a: charging = 'maybe' is invalid: must be true or false"),
    ([{'name': 'a', 'config': 3}], 'robot a: config = 3 is invalid: must be a path to a YAML file'),
    ([{'name': 'a', 'level': 3}], 'robot a: key level is unknown (known: name, config, initial_percentage, '
                                  'charging)'),
])
def test_a_bad_entry_is_one_line_naming_the_robot_and_the_key(robots, message):
    with pytest.raises(FleetError) as error:
        robot_specs(robots)
    assert str(error.value).startswith(message), str(error.value)
    assert '\n' not in str(error.value)


def test_a_prefix_that_makes_no_name_is_refused():
    with pytest.raises(FleetError, match="~prefix = '9' is invalid"):
        robot_specs(2, prefix='9')


def test_each_config_is_loaded_once_and_a_bad_one_names_its_robot():
    from battery_simulator.core.fleet import FleetError, robot_configs, robot_specs
    loads = []

    def load(path):
        loads.append(path)
        if path == 'bad.yaml':
            raise ValueError('no such file')
        return 'params of %s' % path
    robots = robot_specs([{'name': 'a', 'config': 'x.yaml'}, {'name': 'b', 'config': 'x.yaml'},
                          {'name': 'c'}], config='default.yaml')
    assert robot_configs(robots, load, {'default.yaml': 'given'}) == {'default.yaml': 'given',
                                                                       'x.yaml': 'params of x.yaml'}
    assert loads == ['x.yaml']
    with pytest.raises(FleetError, match=r"^robot d: config = 'bad.yaml' is invalid: no such file$"):
        robot_configs(robot_specs([{'name': 'd', 'config': 'bad.yaml'}]), load)


def test_the_fleet_states_message_holds_the_robots_with_a_state():
    from types import SimpleNamespace
    from battery_simulator.core.fleet import fleet_states
    publishers = [('r0', SimpleNamespace(latest_battery=lambda: 'state0')),
                  ('r1', SimpleNamespace(latest_battery=lambda: None)),     # before its first state, or dropout
                  ('r2', SimpleNamespace(latest_battery=lambda: 'state2'))]
    assert fleet_states(publishers) == (['r0', 'r2'], ['state0', 'state2'])


def _fires(every, ticks):
    return sum(1 for now in ticks if every.due(now))


def test_what_the_host_does_every_period_keeps_its_rate_and_phase():
    """The host's one timer ticks at update_rate and reads the clock after stepping every robot (0-0.4 s late at
    1000 robots under load): each thing done every period is done once a period whatever that lateness, spread
    over the ticks of its period, and after a stall goes on at its own phase without a burst to catch up."""
    jitter = random.Random(42)
    ticks = [k + 1.0 + jitter.uniform(0.0, 0.4) for k in range(200)]   # a 1 Hz timer, each tick 0-0.4 s late
    assert _fires(Every(1.0, 1.0, 1.0), ticks) == 200
    fine = [k * 0.1 + 0.1 + jitter.uniform(0.0, 0.04) for k in range(2000)]   # 10 Hz ticks, a 1 Hz status
    assert _fires(Every(0.1, 1.0, 0.1), fine) == 200
    assert _fires(Every(0.1, 1.0 / 3.0, 0.1), fine) in (599, 600, 601), 'a rate that is no multiple of the ticks'
    every = Every(0.1, 1.0, 0.1)
    assert [now for now in fine[:30] if every.due(now)] == [fine[0], fine[10], fine[20]], 'one tick a period'
    every = Every(1.0, 1.0, 1.0)
    assert [every.due(now) for now in (1.0, 2.0, 6.5, 7.0, 8.0)] == [True, True, True, True, True]
    assert every.next == 9.0, 'a stall of 4.5 s: no burst, on at its own phase'
