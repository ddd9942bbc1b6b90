"""The package's layout (docs/development.md): a ROS-free core, two front ends alike and apart, no import circle,
no ROS module over 350 lines. Read from the source (ast), without importing anything."""
import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[2] / 'src' / 'battery_simulator'
ROS_FREE = ('core', 'robot', 'cli', 'web')
FRONT_ENDS = ('ros1', 'ros2')
MAX_ROS_MODULE_LINES = 350
#: the jobs both front ends have: the same module name in ros1/ and ros2/ (docs/development.md's table)
SHARED_JOBS = (
    'battery_sim', 'battery_state_pub',                 # the two mains of sim.launch
    'one_battery', 'battery_settings',                  # one battery's node; start-up settings and its battery
    'action_server', 'services', 'prediction_service',  # the server's action, services, predict
    'state_publisher', 'saved_state', 'velocity', 'messages', 'log', 'startup',
    'fleet_host', 'dashboard', 'doctor', 'client',
    'cmd_vel_gate', 'dock_contact', 'fake_base', 'patrol_and_dock', 'sim_clock', 'twist',   # the robot's loop
)
#: a front end's own jobs, each with why the other has none (a module in neither list fails the mirror)
FRONT_END_ONLY = {
    'ros1': {
        'cached_param': "a parameter followed through the master's pushes (ROS 2 has no parameter server)",
        'workers': "the threads a rospy process shares (rclpy's executor runs ROS 2's timers)",
    },
    'ros2': {
        'battery_claims': 'one battery per name without a master to ask (Part 3 on ROS 2)',
        'local_claims': 'the same claims decided at once between the processes of one machine',
        'qos': 'the QoS profiles (ROS 1 has none)',
        'rcl_args': "rcl's --ros-args errors as one line",
        'respawn': "the launch files' respawn less a start-up failure (roslaunch's respawn has no such gap)",
        'demo': "battery_demo: the demo's nodes in one process (ROS 1's demo is demo.launch)",
        'events_executor': "rclpy's EventsExecutor for a fleet host, Kilted's workarounds (rospy has no executor)",
        'fleet_dds': "the fleet host's Fast DDS profile: its own endpoints unmatched, histories as used (ROS 1 has no DDS)",
    },
}
#: the classes a shared job holds under one name on both sides
SHARED_CLASSES = {
    'action_server': ('BatterySimServer',), 'services': ('BatteryServices',), 'one_battery': ('OneBattery',),
    'state_publisher': ('BatteryStatePublisher',), 'fleet_host': ('FleetHost',), 'log': ('RobotLog',),
    'cmd_vel_gate': ('CmdVelGate',), 'dock_contact': ('DockContact',), 'fake_base': ('FakeBase',),
    'patrol_and_dock': ('PatrolAndDock',), 'sim_clock': ('SimClock',), 'twist': ('TwistSubscriber', 'TwistPublisher'),
}
#: the mains of sim.launch's two nodes: nothing but main(), imported by no module
MAINS = ('battery_sim', 'battery_state_pub')
MAX_MAIN_LINES = 80


def modules():
    """{dotted name: path} of every module of the package."""
    found = {}
    for path in PACKAGE.rglob('*.py'):
        parts = path.relative_to(PACKAGE.parent).with_suffix('').parts
        if parts[-1] == '__init__':
            parts = parts[:-1]
        found['.'.join(parts)] = path
    return found


def imports_of(path):
    """The top-level names of every module ``path`` imports (anywhere in it, lazy imports included)."""
    names = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names.add(node.module)
            names.update(node.module + '.' + alias.name for alias in node.names)
    return names


MODULES = modules()


def package_imports(name):
    """The package's modules that module ``name`` imports."""
    return {imported for imported in imports_of(MODULES[name]) if imported in MODULES and imported != name}


@pytest.mark.parametrize('folder', ROS_FREE)
def test_the_ros_free_folders_import_no_ros(folder):
    for name, path in MODULES.items():
        if name.startswith('battery_simulator.%s' % folder):
            ros = {imported for imported in imports_of(path)
                   if imported.split('.')[0] in ('rospy', 'rclpy', 'actionlib', 'rosgraph')
                   or imported.startswith(('battery_simulator.ros1', 'battery_simulator.ros2',
                                           'battery_simulator.msg', 'battery_simulator.srv'))}
            if folder == 'cli' and name.endswith('client_cli'):
                ros.discard('battery_simulator.ros1')   # main(): the ROS 1 runner, imported after the arguments
                ros = {imported for imported in ros if not imported.startswith('battery_simulator.ros1.client')}
            assert not ros, '%s imports %s' % (name, sorted(ros))


def test_the_front_ends_never_import_each_other():
    for name in MODULES:
        for mine, other in (FRONT_ENDS, FRONT_ENDS[::-1]):
            if name.startswith('battery_simulator.%s' % mine):
                crossing = [imported for imported in package_imports(name)
                            if imported.startswith('battery_simulator.%s' % other)]
                assert not crossing, '%s imports %s' % (name, crossing)


def test_no_import_circle():
    graph = {name: package_imports(name) for name in MODULES}
    # a package imports its __init__ first: an edge to a submodule counts for the package too
    done, path = set(), []

    def visit(name):
        if name in path:
            circle = path[path.index(name):] + [name]
            pytest.fail('import circle: %s' % ' -> '.join(circle))
        if name in done:
            return
        path.append(name)
        for imported in sorted(graph.get(name, ())):
            visit(imported)
        path.pop()
        done.add(name)
    for name in sorted(graph):
        visit(name)


def test_no_ros_module_over_350_lines():
    for name, path in MODULES.items():
        if imports_of(path) & {'rospy', 'rclpy'} or any(
                imported.startswith(('rospy', 'rclpy.')) for imported in imports_of(path)):
            lines = len(path.read_text().splitlines())
            assert lines <= MAX_ROS_MODULE_LINES, '%s has %d lines (at most %d)' % (name, lines,
                                                                                   MAX_ROS_MODULE_LINES)


@pytest.mark.parametrize('job', SHARED_JOBS)
def test_a_job_both_front_ends_have_has_one_name(job):
    for front_end in FRONT_ENDS:
        assert 'battery_simulator.%s.%s' % (front_end, job) in MODULES, '%s/%s.py is missing' % (front_end, job)


def front_end_modules(front_end, modules=None):
    """The module names (``action_server``) of ``front_end``'s folder."""
    prefix = 'battery_simulator.%s.' % front_end
    return {name[len(prefix):] for name in (modules or MODULES) if name.startswith(prefix)}


def mirror_problems(modules):
    """What breaks the mirror in ``modules`` (names as MODULES has them): a module of one front end that is
    neither a shared job present on both sides nor a named extra of its own side."""
    problems = []
    for front_end in FRONT_ENDS:
        mine = front_end_modules(front_end, modules)
        for job in sorted(mine - set(SHARED_JOBS) - set(FRONT_END_ONLY[front_end])):
            problems.append('%s/%s.py is a job of %s only: add its twin to the other front end (SHARED_JOBS), or '
                            'name it in FRONT_END_ONLY with why' % (front_end, job, front_end))
        for job in sorted(set(SHARED_JOBS) - mine):
            problems.append('%s/%s.py is missing (a shared job)' % (front_end, job))
        for job in sorted(set(FRONT_END_ONLY[front_end]) - mine):
            problems.append('%s/%s.py is named in FRONT_END_ONLY but gone' % (front_end, job))
    return problems


def test_every_front_end_module_is_a_shared_job_or_a_named_extra():
    assert mirror_problems(MODULES) == []


def test_a_job_added_on_one_side_only_fails_the_mirror():
    """The check above can fail: a ros1-only module that neither list names is caught, and so is a shared job
    whose twin is gone."""
    job = 'gauge' + '_tuner'   # a module that does not exist (spelled apart: no path to check in this file)
    added = dict(MODULES, **{'battery_simulator.ros1.' + job: None})
    assert mirror_problems(added) == ['ros1/%s.py is a job of ros1 only: add its twin to the other front end '
                                      '(SHARED_JOBS), or name it in FRONT_END_ONLY with why' % job]
    removed = {name: path for name, path in MODULES.items() if name != 'battery_simulator.ros2.velocity'}
    assert mirror_problems(removed) == ['ros2/velocity.py is missing (a shared job)']


def test_no_job_is_both_shared_and_one_sided():
    for front_end in FRONT_ENDS:
        assert not set(SHARED_JOBS) & set(FRONT_END_ONLY[front_end])


def top_level_classes(name):
    return {node.name for node in ast.parse(MODULES[name].read_text()).body if isinstance(node, ast.ClassDef)}


@pytest.mark.parametrize('job', sorted(SHARED_CLASSES))
def test_the_same_classes_in_both_front_ends(job):
    for front_end in FRONT_ENDS:
        missing = set(SHARED_CLASSES[job]) - top_level_classes('battery_simulator.%s.%s' % (front_end, job))
        assert not missing, '%s/%s.py has no class %s' % (front_end, job, ', '.join(sorted(missing)))


@pytest.mark.parametrize('front_end', FRONT_ENDS)
@pytest.mark.parametrize('main', MAINS)
def test_a_main_is_a_few_lines_and_only_main(front_end, main):
    name = 'battery_simulator.%s.%s' % (front_end, main)
    tree = ast.parse(MODULES[name].read_text())
    defined = {node.name for node in tree.body if isinstance(node, (ast.FunctionDef, ast.ClassDef))}
    assert defined == {'main'}, '%s defines %s besides main: they belong to a module of their job' % (
        name, sorted(defined - {'main'}))
    lines = len(MODULES[name].read_text().splitlines())
    assert lines <= MAX_MAIN_LINES, '%s has %d lines (a main: at most %d)' % (name, lines, MAX_MAIN_LINES)


def test_no_module_imports_a_main():
    mains = {'battery_simulator.%s.%s' % (front_end, main) for front_end in FRONT_ENDS for main in MAINS}
    for name in MODULES:
        imported = {i for i in imports_of(MODULES[name]) if i in mains or any(i.startswith(m + '.') for m in mains)}
        # "from battery_simulator.ros1 import battery_sim" names the main as package.attribute
        assert not imported, '%s imports the main %s' % (name, sorted(imported))


def test_no_two_ros_free_classes_share_a_name():
    """A class name says one thing (issue 41: core/battery.py's BatteryRecord and the dashboard's were two
    unrelated classes; the dashboard's is DashboardBattery). The front ends' mirrored classes are exempt."""
    where = {}
    for name, path in MODULES.items():
        parts = name.split('.')
        if len(parts) > 1 and parts[1] in FRONT_ENDS:
            continue
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if isinstance(node, ast.ClassDef):
                assert node.name not in where, 'class %s in %s and %s' % (node.name, where[node.name], name)
                where[node.name] = name


#: modules split or renamed by job (issue 41, docs/development.md): none comes back as a second home
GONE = ('core.names', 'core.topics', 'core.settings', 'core.parameters', 'ros1.battery_sim_server',
        'ros2.robot_node')


@pytest.mark.parametrize('name', GONE)
def test_a_renamed_module_stays_gone(name):
    assert 'battery_simulator.' + name not in MODULES, \
        'battery_simulator/%s.py is back: its job lives elsewhere (docs/development.md)' % name.replace('.', '/')
