"""Issue 40 item 1: the executables started with the arguments ``ros2 launch`` passes (launch_ros gives every
node it starts ``--ros-args [-r __node:=NAME] -r __ns:=NS --params-file FILE``, the namespace '/' when the launch
file gives none; a global remap applies to every node of a process). A fleet host's robots stay at
``NS/robotN/...`` whatever the host is renamed to, and battery_sim's two nodes stay two. Checked on the graph
(node names, and which node publishes each battery_status)."""
import tempfile

import yaml

from ros2_probe import NodeProcess, Probe

import pytest


@pytest.fixture(scope='module')
def probe():
    probe = Probe('global_remaps_probe')
    yield probe
    probe.close()


def params_file(parameters):
    """A parameters file as launch_ros writes one for a Node action's ``parameters=[{...}]``."""
    with tempfile.NamedTemporaryFile('w', suffix='.yaml', prefix='remap_params_', delete=False) as stream:
        yaml.safe_dump({'/**': {'ros__parameters': parameters}}, stream)
    return stream.name


def launched(executable, namespace, parameters, name=None):
    args = (['-r', '__node:=' + name] if name else []) + ['-r', '__ns:=' + namespace,
                                                         '--params-file', params_file(parameters)]
    return NodeProcess(executable, *args)


def node_names(probe):
    return {'%s/%s' % (ns.rstrip('/'), name) for name, ns in probe.node.get_node_names_and_namespaces()}


def status_publishers(probe, topic):
    return sorted('%s/%s' % (info.node_namespace.rstrip('/'), info.node_name)
                  for info in probe.node.get_publishers_info_by_topic(topic))


def wait_until(condition, timeout_s):
    import time
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if condition():
            return True
        time.sleep(0.1)
    return condition()


@pytest.mark.parametrize('namespace, name, host', [
    ('/', None, '/battery_fleet'),                 # ros2 launch with no namespace: every robot stays at /robotN
    ('/site', 'fleet_host', '/site/fleet_host'),   # a namespace and a name: the robots under it, the host renamed
])
def test_a_fleet_host_under_launch_ros_arguments_keeps_one_node_per_robot(probe, namespace, name, host):
    prefix = 'gr%s_' % (name or 'root')
    process = launched('battery_fleet', namespace, {'robots': 3, 'prefix': prefix}, name)
    base = namespace.rstrip('/')
    robots = ['%s/%s%d' % (base, prefix, k) for k in range(3)]
    wanted = {host} | {robot + '/battery_simulator' for robot in robots}
    try:
        assert wait_until(lambda: wanted <= node_names(probe), 30.0), \
            'nodes %s, wanted %s:\n%s' % (sorted(node_names(probe)), sorted(wanted), process.output())
        for robot in robots:
            topic = robot + '/battery_status'
            assert wait_until(lambda: status_publishers(probe, topic) == [robot + '/battery_simulator'], 10.0), \
                '%s published by %s' % (topic, status_publishers(probe, topic))
        renamed = [n for n in node_names(probe) if n.endswith('/' + (name or 'battery_fleet'))]
        assert renamed == [host], 'the host\'s name is the host\'s only: %s' % renamed
    finally:
        assert process.stop() == 0, process.output()


def test_battery_sim_renamed_keeps_two_nodes(probe):
    process = launched('battery_sim', '/grsim', {'initial_percentage': 80.0}, 'my_battery')
    try:
        assert wait_until(lambda: {'/grsim/my_battery', '/grsim/battery_state_pub'} <= node_names(probe), 30.0), \
            '%s:\n%s' % (sorted(node_names(probe)), process.output())
        assert wait_until(lambda: status_publishers(probe, '/grsim/battery_status') == ['/grsim/battery_state_pub'],
                          10.0), status_publishers(probe, '/grsim/battery_status')
        def state_publishers():   # discovery brings a node's name before all of its endpoints
            return [(p.node_namespace, p.node_name)
                    for p in probe.node.get_publishers_info_by_topic('/grsim/battery_simulator/state')]
        assert wait_until(lambda: state_publishers() == [('/grsim', 'my_battery')], 10.0), state_publishers()
    finally:
        assert process.stop() == 0, process.output()
