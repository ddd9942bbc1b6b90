"""A fleet over several hosts, proven on Linux network namespaces (tools/netns_fleet.sh): three fleet hosts of
50 robots, each in a namespace of its own, and an observer namespace (ROS 2: the discovery server and a super
client; ROS 1: the master), joined by a bridge in a fifth. Every robot's battery_status must reach the observer,
a host killed with SIGKILL and started again must resume its robots within 1 %, and nothing may leave this
machine: no namespace of the run has a default route, no ROS process runs in the root namespace, and the tool
refuses to start one in a namespace that has a default route. Where namespaces cannot be made (not root, no
``ip netns``) every test here skips and says why.

Run as root with /usr/bin/python3 (ROS 1: the devel space sourced; ROS 2: tools/ros2.sh sets itself up)."""
import os
import re
import shutil
import subprocess
import threading
import time

import pytest

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), '..', '..'))
TOOL = os.path.join(ROOT, 'tools', 'netns_fleet.sh')
HOSTS, ROBOTS = 3, 50
#: the robots' time scale: at fleet.launch's 22 one second of wall time (a battery_status period, the time a
#: loaded machine takes to write a saved state) is up to 0.8 % of a low battery, so the last level seen before
#: a kill and the resumed one can differ by about 1 % with nothing wrong; at 5 a second is 0.2 % at most
TIME_SCALE = 5
#: what the tool runs in the namespaces, never in the root one (there: only its shell, ip and the ROS 2 set-up)
ROS_WORDS = ('battery_fleet', 'netns_fleet_observer', 'fast-discovery-server', 'roscore', 'rosmaster', 'rosout')


def why_no_namespaces():
    if os.geteuid() != 0:
        return 'not root: cannot make network namespaces'
    if shutil.which('ip') is None:
        return "no 'ip' command (iproute2): cannot make network namespaces"
    if subprocess.run(['ip', 'netns', 'list'], capture_output=True).returncode != 0:
        return "'ip netns' does not work here: cannot make network namespaces"
    return None


pytestmark = pytest.mark.skipif(why_no_namespaces() is not None, reason=str(why_no_namespaces()))


def net_namespace(pid):
    try:
        return os.readlink('/proc/%d/ns/net' % pid)
    except OSError:
        return None


def descendants(pid):
    children = []
    try:
        with open('/proc/%d/task/%d/children' % (pid, pid)) as stream:
            children = [int(c) for c in stream.read().split()]
    except OSError:
        pass
    return children + [d for child in children for d in descendants(child)]


def command_line(pid):
    try:
        with open('/proc/%d/cmdline' % pid, 'rb') as stream:
            return stream.read().replace(b'\0', b' ').decode(errors='replace')
    except OSError:
        return ''


def is_ros_program(line):
    """The program (or the script an interpreter runs) is one the tool runs in a namespace."""
    return any(os.path.basename(word).startswith(ROS_WORDS) for word in line.split()[:2])


class Watch:
    """While the tool runs: its namespaces' default routes, the processes in them, any ROS process at root."""

    def __init__(self, tool):
        self.tool, self.root = tool, net_namespace(os.getpid())
        self.namespaces, self.pids, self.routes, self.at_root = set(), set(), [], []
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _run(self):
        prefix = 'bsf%d' % self.tool.pid
        while self.tool.poll() is None:
            listed = subprocess.run(['ip', 'netns', 'list'], capture_output=True, text=True).stdout.split()
            for ns in [name for name in listed if name.startswith(prefix)]:
                self.namespaces.add(ns)
                for family in ('-4', '-6'):
                    route = subprocess.run(['ip', '-n', ns, family, 'route', 'show', 'default'],
                                           capture_output=True, text=True).stdout.strip()
                    if route:
                        self.routes.append('%s: %s' % (ns, route))
                self.pids.update(int(p) for p in subprocess.run(['ip', 'netns', 'pids', ns], capture_output=True,
                                                                text=True).stdout.split())
            for pid in descendants(self.tool.pid):
                line = command_line(pid)
                if net_namespace(pid) == self.root and is_ros_program(line):
                    self.at_root.append(line)
            time.sleep(0.3)

    def join(self):
        self._thread.join(10.0)


def run_tool(ros):
    tool = subprocess.Popen([TOOL, '--ros', str(ros), '--hosts', str(HOSTS), '--robots', str(ROBOTS), '--resume',
                             '--timeout', '150', '--time-scale', str(TIME_SCALE)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    watch = Watch(tool)
    try:
        out, err = tool.communicate(timeout=420)
    finally:
        if tool.poll() is None:
            tool.terminate()   # its trap ends what it started and deletes its namespaces
            tool.communicate(timeout=60)
    watch.join()
    return tool.returncode, out, err, watch


@pytest.mark.parametrize('ros', [1, 2], ids=['ros1', 'ros2'])
def test_every_robot_reaches_the_observer_and_a_killed_host_resumes(ros):
    code, out, err, watch = run_tool(ros)
    lines = out.splitlines()
    total = HOSTS * ROBOTS
    assert lines and re.fullmatch(r'seen %d of %d robots from the observer host in [0-9.]+ s' % (total, total),
                                  lines[0]), out + err[-3000:]
    resumed = [line for line in lines if line.startswith('host 1 killed with SIGKILL and started again')]
    assert resumed and 'resumed %d of %d robots' % (ROBOTS, ROBOTS) in resumed[0] \
        and '(within 1 %: yes)' in resumed[0] and "%d of %d logged 'resumed from'" % (ROBOTS, ROBOTS) in resumed[0], \
        out + err[-3000:]
    assert code == 0, out + err[-3000:]
    # nothing leaves this machine
    assert len(watch.namespaces) == HOSTS + 2, 'hosts, observer and bridge namespaces: %s' % sorted(watch.namespaces)
    assert not watch.routes, 'a namespace of the run had a default route: %s' % watch.routes
    assert not watch.at_root, 'ROS processes ran in the root namespace: %s' % watch.at_root
    assert watch.pids, 'no process was seen in the namespaces'
    # and nothing is left behind: the namespaces are gone, their processes ended (ip netns del ends none)
    listed = subprocess.run(['ip', 'netns', 'list'], capture_output=True, text=True).stdout.split()
    assert not watch.namespaces & set(listed), 'namespaces left: %s' % (watch.namespaces & set(listed))
    left = [pid for pid in watch.pids if os.path.exists('/proc/%d' % pid) and net_namespace(pid) != watch.root]
    assert not left, 'processes left running: %s' % [command_line(pid) for pid in left]


@pytest.fixture
def namespace_with_a_default_route():
    name = 'bsfroute%d' % os.getpid()
    subprocess.run(['ip', 'netns', 'add', name], check=True)
    try:
        for command in (['link', 'add', 'uplink0', 'type', 'veth', 'peer', 'name', 'uplink1'],
                        ['link', 'set', 'uplink0', 'up'], ['link', 'set', 'uplink1', 'up'],
                        ['addr', 'add', '10.201.0.2/24', 'dev', 'uplink0']):
            subprocess.run(['ip', '-n', name] + command, check=True)
        yield name
    finally:
        subprocess.run(['ip', 'netns', 'del', name])


def test_the_tool_refuses_a_namespace_with_a_default_route(namespace_with_a_default_route):
    ns = namespace_with_a_default_route
    fenced = subprocess.run([TOOL, '--run-in', ns, '--', 'true'], capture_output=True, text=True)
    assert fenced.returncode == 0, fenced.stderr   # no default route yet: it runs
    subprocess.run(['ip', '-n', ns, 'route', 'add', 'default', 'via', '10.201.0.1'], check=True)
    refused = subprocess.run([TOOL, '--run-in', ns, '--', 'touch', '/tmp/bsf_must_not_exist_%d' % os.getpid()],
                             capture_output=True, text=True)
    assert refused.returncode == 2 and 'default route' in refused.stderr, (refused.returncode, refused.stderr)
    assert not os.path.exists('/tmp/bsf_must_not_exist_%d' % os.getpid())
