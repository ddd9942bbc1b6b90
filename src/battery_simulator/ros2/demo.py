"""``battery_demo`` (ROS 2): the whole demo in one process, as ROS 1's demo.launch.

    ros2 run battery_simulator battery_demo [--ros-args -p speed:=240]

The clock (sim_clock), the battery and its publisher (battery_sim's OneBattery: nodes battery_simulator
and battery_state_pub), the base (fake_base, starting off the dock at x 1 m), the dock contact, the cut-off
gate (cmd_vel_nav -> cmd_vel) and patrol_and_dock, composed by hand in this process on one executor, every
node on ``use_sim_time``. The robot patrols, heads for the dock when battery_low turns true, charges,
backs off and patrols again; each phase is logged with the level and published on
``patrol_and_dock/phase``.

:Parameters of battery_demo (demo.launch's arguments):
  - ``speed`` (0 < s <= 10000, default 60): ROS time runs this many times as fast as wall time
  - ``tick_hz`` (Hz, default 100): clock ticks per wall second (0.6 s of ROS time a tick at speed 60,
    2.4 s at 240: every tick wakes every node of this process, and rclpy's executor costs ~1 ms a wake-up)
  - ``initial_percentage`` (0-100, default 40), ``low_percentage`` (0-1, default 0.25): the robot heads for
    the dock below it; ``rate`` (Hz, default 2): battery_status
  - ``gauge`` (``ideal``; ``realistic``: config/battery_realistic.yaml; ``impedance_track`` or ``modelgauge``:
    config/battery_impedance_track.yaml or battery_modelgauge.yaml, a learning gauge, and the robot rests 40 or
    60 min on the dock once full), ``config`` (a YAML file; default by gauge)
  - ``robot_speed`` (m/s, default 0.3), ``dock_x``, ``dock_y`` (m, default 0)
"""
from pathlib import Path

from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter

from battery_simulator.core.config_files import default_config_path
from battery_simulator.core.node_settings import Setting
from battery_simulator.core.parameter_rules import is_number
from battery_simulator.robot import base, clock as clock_rule, dock_contact, patrol
from battery_simulator.robot.demo_gauges import GAUGE_CONFIGS, rest_on_dock_s
from battery_simulator.ros2.battery_sim import OneBattery, finish
from battery_simulator.ros2.cmd_vel_gate import CmdVelGate
from battery_simulator.ros2.dock_contact import DockContact
from battery_simulator.ros2.fake_base import FakeBase
from battery_simulator.ros2.patrol_and_dock import ROS2_DEFAULTS, PatrolAndDock
from battery_simulator.ros2.robot_node import read_settings
from battery_simulator.ros2.sim_clock import SimClock
from battery_simulator.ros2.battery_claims import BatteryClaim
from battery_simulator.ros2.startup import StartupError, ending_quietly, exit_on_startup_error, init, run

GAUGES = GAUGE_CONFIGS
#: a mobile robot's cruising speed at most: the patrol, the dock's approach and its contact assume it
MAX_ROBOT_SPEED = 2.0
#: what else battery_demo takes on its command line (ROS 2's own)
ROS_PARAMETERS = ('use_sim_time', 'start_type_description_service')
SPEED = next(s for s in clock_rule.SETTINGS if s.name == 'speed')
SETTINGS = (
    SPEED._replace(default=60.0, description='the whole demo runs this many times as fast as wall time'),
    Setting('tick_hz', 100.0, lambda v: is_number(v) and 0 < v <= 1000, 'a number in (0, 1000] Hz',
            'clock ticks per wall second (each wakes every node of the demo)', False),
    Setting('initial_percentage', 40.0, lambda v: is_number(v) and 0 <= v <= 100, 'a number in [0, 100]',
            'battery level at start, %', False),
    Setting('low_percentage', 0.25, lambda v: is_number(v) and 0 < v <= 1, 'a fraction in (0, 1]',
            'the robot heads for the dock below this fraction', False),
    Setting('rate', 2.0, lambda v: is_number(v) and 0 < v <= 1000, 'a number in (0, 1000] Hz',
            'battery_status rate, Hz', False),
    Setting('gauge', 'ideal', lambda v: v in GAUGES, 'ideal, realistic, impedance_track or modelgauge',
            'ideal: the robot reads the truth; realistic: an aged pack and a coulomb-counting gauge; '
            'impedance_track, modelgauge: an aged pack and a learning gauge (TI, Analog Devices) that the robot '
            'lets rest on the dock once full', False),
    Setting('config', '', lambda v: isinstance(v, str), 'a path to a YAML file (or empty: by gauge)',
            'battery parameters (empty: config/battery.yaml, or battery_realistic.yaml with gauge realistic)', False),
    Setting('robot_speed', 0.3, lambda v: is_number(v) and 0 < v <= MAX_ROBOT_SPEED,
            'a number in (0, %g] m/s' % MAX_ROBOT_SPEED, "the robot's cruising speed", False),
    Setting('dock_x', 0.0, is_number, 'a number (m)', 'the dock, x (m)', False),
    Setting('dock_y', 0.0, is_number, 'a number (m)', 'the dock, y (m)', False),
)
START_X_M = 1.0   # the base starts off the dock: a robot that starts on it would charge at once


def config_path(settings):
    return settings['config'] or str(Path(default_config_path()).parent / GAUGES[settings['gauge']])


class Demo:
    """The demo's nodes in the demo node's namespace, from its settings. Each node takes only the parameters
    given here (not the command line's: ``speed`` is the clock's, not patrol_and_dock's cruising speed).
    The nodes first (the battery's claim on its name needs them spinning), then ``start_roles()``."""

    def __init__(self, demo_node, settings):
        self.settings = settings
        ns = demo_node.get_namespace()

        def node(name, remaps=(), sim_time=True, **parameters):
            overrides = [Parameter('use_sim_time', value=sim_time)]
            overrides += [Parameter(key, value=value) for key, value in parameters.items()]
            cli = ['--ros-args'] + [arg for remap in remaps for arg in ('-r', remap)] if remaps else None
            return Node(name, namespace=ns, use_global_arguments=False, cli_args=cli,
                        parameter_overrides=overrides)

        dock = dict(dock_x=float(settings['dock_x']), dock_y=float(settings['dock_y']))
        self.clock_node = node('sim_clock', sim_time=False)
        self.battery_node = node('battery_simulator', initial_percentage=float(settings['initial_percentage']),
                                 config=config_path(settings))
        self.status_node = node('battery_state_pub', rate=float(settings['rate']),
                                low_percentage=float(settings['low_percentage']))
        self.base_node = node('fake_base', x=START_X_M)
        self.contact_node = node('battery_dock_contact', **dock)
        self.gate_node = node('battery_cmd_vel_gate', remaps=('cmd_vel_in:=cmd_vel_nav', 'cmd_vel_out:=cmd_vel'))
        self.patrol_node = node('patrol_and_dock', remaps=('cmd_vel:=cmd_vel_nav',),
                                speed=float(settings['robot_speed']),
                                rest_on_dock=rest_on_dock_s(settings['gauge']), **dock)
        self.nodes = [demo_node, self.clock_node, self.battery_node, self.status_node, self.base_node,
                      self.contact_node, self.gate_node, self.patrol_node]
        self.clock = self.battery = None

    def start_roles(self):
        """Each node's role (StartupError for a bad setting); the clock starts with ``clock.start()``."""
        settings = self.settings
        self.clock = SimClock(self.clock_node, settings['speed'], 0.0, settings['tick_hz'], start_now=False)
        self.battery = OneBattery(self.battery_node, self.status_node)
        self.base = FakeBase(self.base_node, **read_settings(self.base_node, base.SETTINGS))
        self.contact = DockContact(self.contact_node, **read_settings(self.contact_node, dock_contact.SETTINGS))
        self.gate = CmdVelGate(self.gate_node)
        self.patrol = PatrolAndDock(self.patrol_node,
                                    **read_settings(self.patrol_node, patrol.SETTINGS, ROS2_DEFAULTS))

    def finish(self):
        """At a stop signal: the clock stops, the battery's goal ends and its state is saved."""
        if self.clock is not None:
            self.clock.stop()
        return finish(self.battery.front) if self.battery is not None else (lambda: True)


def main(args=None):
    with ending_quietly():
        init(args)
        demo_node = Node('battery_demo')
        settings = read_settings(demo_node, SETTINGS)
        unknown = sorted(set(demo_node._parameter_overrides) - {s.name for s in SETTINGS} - set(ROS_PARAMETERS))
        if unknown:   # rclpy keeps no public view of the overrides
            exit_on_startup_error(StartupError('parameter %s is not a parameter of %s; its parameters: %s' % (
                unknown[0], demo_node.get_fully_qualified_name(), ', '.join(s.name for s in SETTINGS))),
                demo_node.get_logger())
        demo = Demo(demo_node, settings)
        executor = SingleThreadedExecutor()
        for node in demo.nodes:
            executor.add_node(node)
        claim = BatteryClaim(demo.battery_node, [demo.battery_node.get_namespace()],
                             demo.battery_node.get_fully_qualified_name())
        try:
            claim.wait(executor)
            demo.start_roles()
        except StartupError as error:
            exit_on_startup_error(error, demo_node.get_logger())
        demo_node.get_logger().info(
            'battery_demo: speed x%g (%g ticks a second), level %g %%, dock below %g %%, gauge %s' % (
                settings['speed'], settings['tick_hz'], settings['initial_percentage'],
                100.0 * settings['low_percentage'], settings['gauge']))
        demo.battery.report_ready()
        demo.clock.start()
        run(executor, demo.finish, claim)


if __name__ == "__main__":
    main()
