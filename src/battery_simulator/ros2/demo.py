"""``battery_demo`` (ROS 2): the whole demo in one process, as ROS 1's demo.launch.

    ros2 run battery_simulator battery_demo [--ros-args -p speed:=240]

The clock (sim_clock), the battery and its publisher (battery_sim's OneBattery: nodes battery_simulator
and battery_state_pub), the base (fake_base, starting off the dock at x 1 m), the dock contact, the cut-off
gate (cmd_vel_nav -> cmd_vel) and patrol_and_dock, composed by hand in this process on one executor, every
node on ``use_sim_time``. The robot patrols, heads for the dock when battery_low turns true, charges,
backs off and patrols again; each phase is logged with the level and published on
``patrol_and_dock/phase``.

The clock is paced on the robot's ``cmd_vel`` as demo.launch's (robot/clock.py's Pace): each tick waits (at most
0.5 s of wall time) for the robot's command since the last one, so ROS time never runs ahead of the controller.
Unpaced, at speed 240 a controller a few wall milliseconds late left the robot standing (its command timed out)
while the battery drained, or stopped inside the dock's radius on patrol: test_demo failed 3 of 5 runs (docked
at 20.2 % against 25 %, the contact closed on patrol at (0.10, 0.23), and once the robot passed over the dock,
never got the contact and ran empty). The nodes spin on rclpy's EventsExecutor (events_executor.py): the
SingleThreadedExecutor rebuilds its wait set over every entity of the eight nodes at each wake-up, and paced on
it the clock ran so slowly under two CPU hogs that a cycle took over 150 s (a7117c1); on the EventsExecutor the
paced demo keeps its 250 ticks a second on a quiet machine.

:Parameters of battery_demo (demo.launch's arguments; robot/demo_settings.py SETTINGS):
  - ``speed`` (0 < s <= 10000, default 60): ROS time runs this many times as fast as wall time
  - ``tick_hz`` (Hz, default 250, as demo.launch's): clock ticks per wall second (0.24 s of ROS time a tick at
    speed 60, 0.96 s at 240: every tick wakes every node of this process, and rclpy's executor costs ~1 ms a
    wake-up)
  - ``initial_percentage`` (0-100, default 40), ``low_percentage`` (0-1, default 0.25): the robot heads for
    the dock below it; ``rate`` (Hz, default 2): battery_status
  - ``gauge`` (``ideal``; ``realistic``: config/battery_realistic.yaml; ``impedance_track`` or ``modelgauge``:
    config/battery_impedance_track.yaml or battery_modelgauge.yaml, a learning gauge, and the robot rests 40 or
    60 min on the dock once full), ``config`` (a YAML file; default by gauge)
  - ``robot_speed`` (m/s, default 0.3), ``dock_x``, ``dock_y`` (m, default 0)
"""
from pathlib import Path

from rclpy.node import Node
from rclpy.parameter import Parameter

from battery_simulator.core.config_files import default_config_path
from battery_simulator.robot import base, dock_contact, patrol
from battery_simulator.robot.demo_gauges import GAUGE_CONFIGS, rest_on_dock_s
from battery_simulator.robot.demo_settings import CLOCK_PACE_ON, SETTINGS, START_X_M
from battery_simulator.ros2.one_battery import OneBattery
from battery_simulator.ros2.cmd_vel_gate import CmdVelGate
from battery_simulator.ros2.dock_contact import DockContact
from battery_simulator.ros2.events_executor import many_entities_executor
from battery_simulator.ros2.fake_base import FakeBase
from battery_simulator.ros2.patrol_and_dock import ROS2_DEFAULTS, PatrolAndDock
from battery_simulator.ros2.sim_clock import SimClock
from battery_simulator.ros2.battery_claims import BatteryClaim
from battery_simulator.ros2.startup import StartupError, ending_quietly, exit_on_startup_error, init, read_settings, run

#: what else battery_demo takes on its command line (ROS 2's own)
ROS_PARAMETERS = ('use_sim_time', 'start_type_description_service')


def config_path(settings):
    return settings['config'] or str(Path(default_config_path()).parent / GAUGE_CONFIGS[settings['gauge']])


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
        self.clock = SimClock(self.clock_node, settings['speed'], 0.0, settings['tick_hz'], start_now=False,
                              pace_on=list(CLOCK_PACE_ON))
        self.battery = OneBattery(self.battery_node, self.status_node)
        self.base = FakeBase(self.base_node, **read_settings(self.base_node, base.SETTINGS))
        self.contact = DockContact(self.contact_node, **read_settings(self.contact_node, dock_contact.SETTINGS))
        self.gate = CmdVelGate(self.gate_node)
        self.patrol = PatrolAndDock(self.patrol_node,
                                    **read_settings(self.patrol_node, patrol.SETTINGS, ROS2_DEFAULTS))

    def finish(self):
        """At a stop signal: the clock stops, the battery's goal ends and its state is saved."""
        if self.clock is not None:
            self.clock.finish()
        return self.battery.finish() if self.battery is not None else (lambda: True)


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
        executor = many_entities_executor()
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
