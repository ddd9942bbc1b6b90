"""The ROS 2 launch files (launch/*.launch.py), without the launch runtime (it does not install here):
each file is read with a small stand-in for the launch and launch_ros modules that records its Node actions
(arguments, OpaqueFunction, IncludeLaunchDescription), and every node it names is started with its
parameters (a parameters file, as launch_ros writes one), name, namespace and remappings through this
environment, and must come up: its node on the graph, and the topic it publishes."""
import contextlib
import importlib.util
import os
import socket
import sys
import tempfile
import time
import types
from pathlib import Path

import pytest
import yaml

from ros2_probe import NodeProcess, Probe

LAUNCH = Path(__file__).resolve().parents[2] / 'launch'
#: what each executable publishes when it is up (relative to its namespace; after remapping)
PUBLISHES = {'battery_sim': 'battery_status', 'sim_clock': '/clock', 'fake_base': 'odom',
             'battery_dock_contact': 'charger_contact', 'battery_cmd_vel_gate': 'cmd_vel_out',
             'patrol_and_dock': 'patrol_and_dock/phase', 'battery_fleet': '/battery_fleet/states',
             'battery_dashboard': None}
NODE_NAMES = {'battery_sim': ['battery_simulator', 'battery_state_pub'], 'battery_fleet': ['battery_fleet']}


class Recorded:
    """A launch action as given: its keyword arguments."""

    def __init__(self, *args, **kwargs):
        self.args, self.kwargs = args, kwargs


class LaunchDescription(Recorded):
    pass


class DeclareLaunchArgument(Recorded):
    pass


class OpaqueFunction(Recorded):
    pass


class IncludeLaunchDescription(Recorded):
    pass


class PythonLaunchDescriptionSource(Recorded):
    pass


class Node(Recorded):
    pass


class RegisterEventHandler(Recorded):
    pass


class OnProcessExit(Recorded):
    pass


class TimerAction(Recorded):
    pass


class Shutdown(Recorded):
    pass


def stand_in_modules():
    """launch, launch.actions, launch.launch_description_sources, launch_ros.actions and
    ament_index_python.packages: just what the launch files use."""
    modules = {name: types.ModuleType(name) for name in (
        'launch', 'launch.actions', 'launch.launch_description_sources', 'launch.event_handlers', 'launch_ros',
        'launch_ros.actions', 'ament_index_python', 'ament_index_python.packages')}
    modules['launch.actions'].RegisterEventHandler = RegisterEventHandler
    modules['launch.actions'].TimerAction = TimerAction
    modules['launch.actions'].Shutdown = Shutdown
    modules['launch.event_handlers'].OnProcessExit = OnProcessExit
    modules['launch'].LaunchDescription = LaunchDescription
    modules['launch.actions'].DeclareLaunchArgument = DeclareLaunchArgument
    modules['launch.actions'].OpaqueFunction = OpaqueFunction
    modules['launch.actions'].IncludeLaunchDescription = IncludeLaunchDescription
    modules['launch.launch_description_sources'].PythonLaunchDescriptionSource = PythonLaunchDescriptionSource
    modules['launch_ros.actions'].Node = Node
    share = os.environ['AMENT_PREFIX_PATH'].split(':')[0] + '/share/battery_simulator'
    modules['ament_index_python.packages'].get_package_share_directory = lambda package: share
    return modules


@contextlib.contextmanager
def standing_in(modules=None):
    """The stand-in launch modules in sys.modules (a launch file imports them, and so does its respawn rule when
    an exit handler runs); the real ones (none here) back afterwards."""
    modules = modules or stand_in_modules()
    saved = {name: sys.modules.get(name) for name in modules}
    sys.modules.update(modules)
    try:
        yield modules
    finally:
        for name, old in saved.items():
            if old is None:
                sys.modules.pop(name, None)
            else:
                sys.modules[name] = old


def actions_of(path, arguments=None, modules=None):
    """Every action a launch file gives with ``arguments`` (its defaults for the rest), includes followed."""
    with standing_in(modules) as modules:
        spec = importlib.util.spec_from_file_location('launch_file_%s' % Path(path).stem.replace('.', '_'), path)
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        description = module.generate_launch_description()
        return _expanded(description, arguments, modules)


def nodes_of(path, arguments=None, modules=None):
    """[Node] a launch file starts with ``arguments`` (its defaults for the rest), includes followed."""
    return [action for action in actions_of(path, arguments, modules) if isinstance(action, Node)]


def _expanded(description, arguments, modules):
    values = {}
    found = []
    for action in description.args[0]:
        if isinstance(action, DeclareLaunchArgument):
            name = action.args[0] if action.args else action.kwargs['name']
            values[name] = str(action.kwargs['default_value'])
    values.update(arguments or {})
    context = types.SimpleNamespace(launch_configurations=values)
    for action in description.args[0]:
        if isinstance(action, OpaqueFunction):
            for made in action.kwargs['function'](context) or []:
                if isinstance(made, IncludeLaunchDescription):
                    source = made.args[0]
                    found += actions_of(source.args[0], dict(made.kwargs.get('launch_arguments', ())), modules)
                else:
                    found.append(made)
        else:
            found.append(action)
    return found


def ros_args(node, params_dir):
    """The command line launch_ros gives a Node action: --ros-args, name, namespace, remaps, parameters (a file
    of its own for each node: two hosts of one executable must not share one)."""
    kwargs = node.kwargs
    args = []
    if kwargs.get('name'):
        args += ['-r', '__node:=%s' % kwargs['name']]
    # launch_ros passes the namespace to every node, '/' when the launch file gives none
    args += ['-r', '__ns:=/%s' % (kwargs.get('namespace') or '').strip('/')]
    for source, target in kwargs.get('remappings', ()):
        args += ['-r', '%s:=%s' % (source, target)]
    for index, parameters in enumerate(kwargs.get('parameters', ())):
        path = tempfile.NamedTemporaryFile(dir=params_dir, prefix='%s_%d_' % (kwargs['executable'], index),
                                           suffix='.yaml', delete=False).name
        with open(path, 'w', encoding='utf-8') as stream:
            yaml.safe_dump({'/**': {'ros__parameters': dict(parameters)}}, stream)
        args += ['--params-file', path]
    return args


def resolved(namespace, name):
    if name.startswith('/'):
        return name
    return '/' + '/'.join(part for part in (namespace.strip('/'), name) if part)


def installed(executable):
    return any(os.access(os.path.join(d, executable), os.X_OK) for d in os.environ['PATH'].split(':'))


@pytest.fixture(scope='module')
def probe():
    probe = Probe('launch_probe')
    yield probe
    probe.close()


def wait_until(condition, timeout_s):
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if condition():
            return True
        time.sleep(0.1)
    return condition()


CASES = {
    'sim.launch.py': [{}, {'speed': '60', 'namespace': 'robot1', 'initial_percentage': '80'}],
    'demo.launch.py': [{'speed': '240'}],
    'fleet.launch.py': [{'n': '5', 'hosts': '2', 'speed': '60'}],
    'dashboard.launch.py': [{'port': 'free'}],   # a free port of PORTS, found when the test runs
}
PORTS = range(18700, 18800)   # this test's dashboards listen here only (rostest dashboard.test has 18093)


def free_port():
    for port in PORTS:
        with socket.socket() as probe_socket:
            try:
                probe_socket.bind(('127.0.0.1', port))
                return port
            except OSError:
                continue
    raise AssertionError('no free port in %d-%d' % (PORTS[0], PORTS[-1]))


def test_every_launch_file_is_exercised():
    assert sorted(p.name for p in LAUNCH.glob('*.launch.py')) == sorted(CASES)


def test_the_launch_files_start_the_executables_and_parameters_of_their_ros1_twins():
    demo = {n.kwargs['executable']: n for n in nodes_of(LAUNCH / 'demo.launch.py')}
    assert sorted(demo) == ['battery_cmd_vel_gate', 'battery_dock_contact', 'battery_sim', 'fake_base',
                            'patrol_and_dock', 'sim_clock']
    assert all(n.kwargs['parameters'][0]['use_sim_time'] for n in demo.values()
               if n.kwargs['executable'] != 'sim_clock')
    assert demo['battery_sim'].kwargs['parameters'][0]['low_percentage'] == 0.25
    assert demo['battery_sim'].kwargs['parameters'][0]['initial_percentage'] == 40.0
    assert demo['sim_clock'].kwargs['parameters'][0]['speed'] == 60.0
    assert demo['sim_clock'].kwargs['parameters'][0]['pace_on'] == ['cmd_vel'], 'paced on the robot, as demo.launch'
    assert demo['patrol_and_dock'].kwargs['parameters'][0]['speed'] == 0.3
    assert ('cmd_vel', 'cmd_vel_nav') in demo['patrol_and_dock'].kwargs['remappings']
    sim = nodes_of(LAUNCH / 'sim.launch.py')
    assert [n.kwargs['executable'] for n in sim] == ['battery_sim']
    assert sim[0].kwargs['parameters'][0]['battery_state_topic'] == 'battery_state'
    assert sim[0].kwargs['parameters'][0]['state_file'], 'a state file of its own: a respawned battery resumes'
    assert sim[0].kwargs['parameters'][0]['time_scale'] == 22.0 and not sim[0].kwargs['parameters'][0]['use_sim_time']
    dashboard = nodes_of(LAUNCH / 'dashboard.launch.py', {'allow_control': 'true'})
    assert dashboard[0].kwargs['parameters'][0] == {'host': '127.0.0.1', 'port': 8090, 'allow_control': True,
                                                    'history_s': 600.0, 'scan_period': 2.0}


@pytest.mark.parametrize('launch_file, arguments', [(f, a) for f, cases in CASES.items() for a in cases])
def test_every_node_of_a_launch_file_comes_up(probe, launch_file, arguments):
    arguments = {name: str(free_port()) if value == 'free' else value for name, value in arguments.items()}
    nodes = nodes_of(LAUNCH / launch_file, arguments)
    assert nodes, '%s starts nothing' % launch_file
    missing = [n.kwargs['executable'] for n in nodes if not installed(n.kwargs['executable'])]
    if missing:
        pytest.skip('not installed in this checkout yet: %s' % ', '.join(missing))
    params_dir = tempfile.mkdtemp(prefix='launch_params_')
    processes = []
    try:
        for node in nodes:
            processes.append((node, NodeProcess(node.kwargs['executable'], *ros_args(node, params_dir))))
        for node, process in processes:
            executable, ns = node.kwargs['executable'], node.kwargs.get('namespace', '')
            names = [node.kwargs['name']] if node.kwargs.get('name') else NODE_NAMES.get(executable, [executable])
            full = {resolved(ns, name) for name in names}
            assert wait_until(lambda: full <= {resolved(n_ns, n) for n, n_ns in
                                               probe.node.get_node_names_and_namespaces()}, 30.0), \
                '%s of %s did not come up (%s):\n%s' % (executable, launch_file, sorted(full), process.output())
            topic = PUBLISHES[executable]
            if topic is not None:
                topic = dict((s, t) for s, t in node.kwargs.get('remappings', ())).get(topic, topic)
                topic = resolved(ns, topic)
                assert wait_until(lambda: probe.node.count_publishers(topic) > 0, 30.0), \
                    '%s of %s publishes no %s:\n%s' % (executable, launch_file, topic, process.output())
            assert process.process.poll() is None, process.output()
    finally:
        for node, process in processes:
            process.stop()
    for node, process in processes:
        assert 'Traceback' not in process.output(), process.output()


# -- issue 40 item 2: a process that ends with the start-up exit status is not respawned ----------------------

def exit_handlers(actions, executable):
    """[(Node, on_exit)] of every ``executable`` Node a launch gives, with its OnProcessExit handler's function."""
    handlers = {id(action.args[0].kwargs['target_action']): action.args[0].kwargs['on_exit'] for action in actions
                if isinstance(action, RegisterEventHandler) and isinstance(action.args[0], OnProcessExit)}
    return [(action, handlers.get(id(action))) for action in actions
            if isinstance(action, Node) and action.kwargs['executable'] == executable]


@pytest.mark.parametrize('launch_file, arguments, executable', [
    ('sim.launch.py', {}, 'battery_sim'), ('demo.launch.py', {}, 'battery_sim'),
    ('fleet.launch.py', {'n': '4', 'hosts': '2'}, 'battery_fleet')])
def test_a_start_up_error_ends_the_launch_and_anything_else_respawns(launch_file, arguments, executable):
    """launch's OnProcessExit handler of each battery process, called as launch calls it (an exit event with
    its return code, the launch context), through the stand-in modules: exit 2 (a bad argument, a duplicate)
    gives Shutdown and no new process; a crash or SIGKILL gives the same node again after 1 s; nothing while
    the launch is shutting down. launch_ros's own respawn (any exit) is not used."""
    with standing_in() as modules:
        actions = actions_of(LAUNCH / launch_file, arguments, modules)
        pairs = exit_handlers(actions, executable)
        assert pairs and len(pairs) == (2 if executable == 'battery_fleet' else 1), pairs
        for node, on_exit in pairs:
            assert not node.kwargs.get('respawn'), 'launch_ros respawns whatever the exit status'
            assert on_exit is not None, '%s of %s has no exit handler' % (executable, launch_file)
            running = types.SimpleNamespace(is_shutdown=False)
            ended = on_exit(types.SimpleNamespace(returncode=2), running)
            assert [type(a) for a in ended] == [Shutdown], 'exit 2 is respawned: %r' % ended
            for code in (1, -9, 0):
                again = on_exit(types.SimpleNamespace(returncode=code), running)
                assert [type(a) for a in again] == [TimerAction] and again[0].kwargs['period'] == 1.0, again
                respawned = [a for a in again[0].kwargs['actions'] if isinstance(a, Node)]
                assert [n.kwargs for n in respawned] == [node.kwargs], 'the same node again'
                assert exit_handlers(again[0].kwargs['actions'], executable)[0][1] is not None, \
                    'the respawned node has the same rule'
            assert not on_exit(types.SimpleNamespace(returncode=-2), types.SimpleNamespace(is_shutdown=True))


def test_the_respawn_rule():
    from battery_simulator.ros2.respawn import END_LAUNCH, NOTHING, RESPAWN, after_exit
    assert after_exit(2, False) == END_LAUNCH
    assert [after_exit(code, False) for code in (0, 1, -9, -11, 3)] == [RESPAWN] * 5
    assert after_exit(2, True) == after_exit(-2, True) == NOTHING


def test_fleet_launch_hosts_share_no_state_file():
    nodes = nodes_of(LAUNCH / 'fleet.launch.py', {'n': '4', 'hosts': '2', 'state_file': '/tmp/fleet.json'})
    files = [n.kwargs['parameters'][0]['state_file'] for n in nodes if n.kwargs['executable'] == 'battery_fleet']
    assert files == ['/tmp/fleet_0.json', '/tmp/fleet_1.json']
    one = nodes_of(LAUNCH / 'fleet.launch.py', {'n': '4', 'state_file': '/tmp/fleet.json'})
    assert [n.kwargs['parameters'][0]['state_file'] for n in one] == ['/tmp/fleet.json']
