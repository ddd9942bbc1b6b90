"""The package's layout (docs/development.md): a ROS-free core, two front ends alike and apart, no import circle,
no ROS module over 350 lines. Read from the source (ast), without importing anything."""
import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[2] / 'src' / 'battery_simulator'
ROS_FREE = ('core', 'robot', 'cli', 'web')
FRONT_ENDS = ('ros1', 'ros2')
MAX_ROS_MODULE_LINES = 350
#: the jobs both front ends have: the same module name in ros1/ and ros2/
SHARED_JOBS = ('action_server', 'state_publisher', 'fleet_host', 'startup', 'log', 'messages', 'client')


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


def test_the_same_classes_in_both_front_ends():
    def classes(name):
        return {node.name for node in ast.parse(MODULES[name].read_text()).body if isinstance(node, ast.ClassDef)}
    for job, cls in (('action_server', 'BatterySimServer'), ('state_publisher', 'BatteryStatePublisher'),
                     ('fleet_host', 'FleetHost')):
        for front_end in FRONT_ENDS:
            assert cls in classes('battery_simulator.%s.%s' % (front_end, job)), \
                '%s/%s.py has no class %s' % (front_end, job, cls)


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
GONE = ('core.names', 'core.topics', 'core.settings', 'core.parameters')


@pytest.mark.parametrize('name', GONE)
def test_a_renamed_module_stays_gone(name):
    assert 'battery_simulator.' + name not in MODULES, \
        'battery_simulator/%s.py is back: its job lives elsewhere (docs/development.md)' % name.replace('.', '/')
