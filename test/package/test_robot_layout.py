"""The robot's loop laid out as issue 34 asks (read from the source, nothing imported): each rule ROS-free in
robot/, a thin adapter of the same module name in ros1/ and ros2/, an executable for each (ROS 1 with .py,
ROS 2 without), each ROS 2 executable among node_signals.py's NODE_SCRIPTS, the launch files of both."""
import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
PACKAGE = ROOT / 'src' / 'battery_simulator'
#: module of each front end -> (its rule in robot/, the executable's name)
LOOP = {'fake_base': ('base', 'fake_base'), 'dock_contact': ('dock_contact', 'battery_dock_contact'),
        'cmd_vel_gate': ('cmd_vel_gate', 'battery_cmd_vel_gate'), 'patrol_and_dock': ('patrol', 'patrol_and_dock'),
        'sim_clock': ('clock', 'sim_clock'), 'twist': (None, None)}


def imported(path):
    names = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom) and node.module:
            names.update('%s.%s' % (node.module, alias.name) for alias in node.names)
            names.add(node.module)
        elif isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
    return names


@pytest.mark.parametrize('module', sorted(LOOP))
def test_each_loop_node_has_the_same_module_in_both_front_ends_over_its_rule(module):
    rule, executable = LOOP[module]
    for front_end in ('ros1', 'ros2'):
        path = PACKAGE / front_end / (module + '.py')
        assert path.is_file(), '%s/%s.py is missing' % (front_end, module)
        if rule:
            names = imported(path)
            assert 'battery_simulator.robot.%s' % rule in names, \
                '%s/%s.py does not use robot/%s.py' % (front_end, module, rule)
    if executable:
        assert (ROOT / 'scripts' / (executable + '.py')).is_file()
        assert (ROOT / 'scripts' / 'ros2' / executable).is_file()


def test_every_ros2_executable_of_the_loop_gets_the_signal_handlers():
    tree = ast.parse((PACKAGE / 'node_signals.py').read_text())
    scripts = next(ast.literal_eval(node.value) for node in tree.body
                   if isinstance(node, ast.Assign) and getattr(node.targets[0], 'id', '') == 'NODE_SCRIPTS')
    for _, executable in LOOP.values():
        if executable:
            assert executable in scripts and executable + '.py' in scripts, executable
    assert 'battery_demo' in scripts


def test_the_ros1_launch_files_have_ros2_twins():
    for launch in ('sim', 'demo', 'fleet', 'dashboard'):
        assert (ROOT / 'launch' / (launch + '.launch')).is_file()
        assert (ROOT / 'launch' / (launch + '.launch.py')).is_file(), 'launch/%s.launch.py is missing' % launch
