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
  - ``gauge`` (``ideal`` or ``realistic``: config/battery_realistic.yaml), ``config`` (a YAML file; default
    by gauge)
  - ``robot_speed`` (m/s, default 0.3), ``dock_x``, ``dock_y`` (m, default 0)
"""
from pathlib import Path

import rclpy
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter

from battery_simulator.core.parameters import default_config_path, is_number
from battery_simulator.core.settings import Setting
from battery_simulator.robot import base, clock as clock_rule, dock_contact, patrol
from battery_simulator.ros2.battery_sim import OneBattery
from battery_simulator.ros2.cmd_vel_gate import CmdVelGate
from battery_simulator.ros2.dock_contact import DockContact
from battery_simulator.ros2.fake_base import FakeBase
from battery_simulator.ros2.patrol_and_dock import ROS2_DEFAULTS, PatrolAndDock
from battery_simulator.ros2.robot_node import read_settings, spin_until_stopped
from battery_simulator.ros2.sim_clock import SimClock
from battery_simulator.ros2.startup import StartupError, ending_quietly, exit_on_startup_error

GAUGES = {'ideal': 'battery.yaml', 'realistic': 'battery_realistic.yaml'}
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
    Setting('gauge', 'ideal', lambda v: v in GAUGES, 'ideal or realistic',
            'ideal: the robot reads the truth; realistic: an aged pack and a coulomb-counting gauge', False),
    Setting('config', '', lambda v: isinstance(v, str), 'a path to a YAML file (or empty: by gauge)',
            'battery parameters (empty: config/battery.yaml, or battery_realistic.yaml with gauge realistic)', False),
    Setting('robot_speed', 0.3, lambda v: is_number(v) and v > 0, 'a number > 0 m/s', "the robot's cruising speed",
            False),
    Setting('dock_x', 0.0, is_number, 'a number (m)', 'the dock, x (m)', False),
    Setting('dock_y', 0.0, is_number, 'a number (m)', 'the dock, y (m)', False),
)
START_X_M = 1.0   # the base starts off the dock: a robot that starts on it would charge at once


def config_path(settings):
    return settings['config'] or str(Path(default_config_path()).parent / GAUGES[settings['gauge']])


class Demo:
    """The demo's nodes in ``namespace``, from the demo node's settings. Each node takes only the parameters
    given here (not the command line's: ``speed`` is the clock's, not patrol_and_dock's cruising speed)."""

    def __init__(self, demo_node, settings):
        ns = demo_node.get_namespace()

        def node(name, remaps=(), sim_time=True, **parameters):
            overrides = [Parameter('use_sim_time', value=sim_time)]
            overrides += [Parameter(key, value=value) for key, value in parameters.items()]
            cli = ['--ros-args'] + [arg for remap in remaps for arg in ('-r', remap)] if remaps else None
            return Node(name, namespace=ns, use_global_arguments=False, cli_args=cli,
                        parameter_overrides=overrides)

        self.clock_node = node('sim_clock', sim_time=False)
        self.clock = SimClock(self.clock_node, settings['speed'], 0.0, settings['tick_hz'], start_now=False)
        battery_node = node('battery_simulator', initial_percentage=float(settings['initial_percentage']),
                            config=config_path(settings))
        status_node = node('battery_state_pub', rate=float(settings['rate']),
                           low_percentage=float(settings['low_percentage']))
        self.battery = OneBattery(battery_node, status_node)
        base_node = node('fake_base', x=START_X_M)
        self.base = FakeBase(base_node, **read_settings(base_node, base.SETTINGS))
        contact_node = node('battery_dock_contact', dock_x=float(settings['dock_x']), dock_y=float(settings['dock_y']))
        self.contact = DockContact(contact_node, **read_settings(contact_node, dock_contact.SETTINGS))
        gate_node = node('battery_cmd_vel_gate', remaps=('cmd_vel_in:=cmd_vel_nav', 'cmd_vel_out:=cmd_vel'))
        self.gate = CmdVelGate(gate_node)
        patrol_node = node('patrol_and_dock', remaps=('cmd_vel:=cmd_vel_nav',), speed=float(settings['robot_speed']),
                           dock_x=float(settings['dock_x']), dock_y=float(settings['dock_y']))
        self.patrol = PatrolAndDock(patrol_node, **read_settings(patrol_node, patrol.SETTINGS, ROS2_DEFAULTS))
        self.nodes = [demo_node, self.clock_node, battery_node, status_node, base_node, contact_node, gate_node,
                      patrol_node]


def main(args=None):
    with ending_quietly():
        rclpy.init(args=args)
        demo_node = Node('battery_demo')
        settings = read_settings(demo_node, SETTINGS)
        try:
            demo = Demo(demo_node, settings)
        except StartupError as error:
            exit_on_startup_error(error, demo_node.get_logger())
        executor = SingleThreadedExecutor()
        for node in demo.nodes:
            executor.add_node(node)
        demo_node.get_logger().info(
            'battery_demo: speed x%g (%g ticks a second), level %g %%, dock below %g %%, gauge %s' % (
                settings['speed'], settings['tick_hz'], settings['initial_percentage'],
                100.0 * settings['low_percentage'], settings['gauge']))
        demo.battery.report_ready()
        demo.clock.start()
        try:
            spin_until_stopped(executor)
        finally:
            demo.clock.stop()
            demo.battery.front.finish()


if __name__ == "__main__":
    main()
