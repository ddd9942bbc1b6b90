"""The demo's settings, written once (no ROS): battery_demo's parameters (ros2/demo.py), demo.launch.py's
arguments (their defaults read from here) and demo.launch's (the same defaults, checked against these by
test/robot/test_demo_settings.py: roslaunch's XML cannot import Python).

``tick_hz`` is 250 in all three (it was 100 in battery_demo): 0.24 s of ROS time a tick at speed 60, as
sim.launch under demo.launch has always ticked; 1000 (Gazebo's) would make every node handle 1000 /clock
messages a second.
"""
from battery_simulator.core.node_settings import Setting
from battery_simulator.core.parameter_rules import is_number
from battery_simulator.robot import clock
from battery_simulator.robot.demo_gauges import GAUGE_CONFIGS

#: a mobile robot's cruising speed at most: the patrol, the dock's approach and its contact assume it
MAX_ROBOT_SPEED = 2.0
#: the base starts off the dock: a robot that starts on it would charge at once
START_X_M = 1.0
#: ROS time starts once every node of the demo is up (sim_clock's wait_for): a slow start costs no battery
CLOCK_WAIT_FOR = ('battery_simulator/state', 'battery_status', 'battery_low', 'odom', 'charger_contact', 'cmd_vel',
                  'patrol_and_dock/phase')
#: each tick of the demo's clock waits for the robot's next command (sim_clock's pace_on, robot/clock.py's Pace):
#: on a busy machine ROS time would otherwise run on while the controller is late and the robot stands
CLOCK_PACE_ON = ('cmd_vel',)

_SPEED = next(s for s in clock.SETTINGS if s.name == 'speed')
SETTINGS = (
    _SPEED._replace(default=60.0, description='the whole demo runs this many times as fast as wall time'),
    Setting('tick_hz', 250.0, lambda v: is_number(v) and 0 < v <= 1000, 'a number in (0, 1000] Hz',
            'sim_clock ticks per wall second (each wakes every node of the demo)', False),
    Setting('initial_percentage', 40.0, lambda v: is_number(v) and 0 <= v <= 100, 'a number in [0, 100]',
            'battery level at start, %', False),
    Setting('low_percentage', 0.25, lambda v: is_number(v) and 0 < v <= 1, 'a fraction in (0, 1]',
            'the robot heads for the dock below this fraction', False),
    Setting('rate', 2.0, lambda v: is_number(v) and 0 < v <= 1000, 'a number in (0, 1000] Hz',
            'battery_status rate, Hz', False),
    Setting('gauge', 'ideal', lambda v: v in GAUGE_CONFIGS, 'ideal, realistic, impedance_track or modelgauge',
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


def default(name):
    """The default of the demo setting ``name``."""
    return next(s.default for s in SETTINGS if s.name == name)


def launch_default(name):
    """The default as a launch file's argument spells it ('60', '0.25', 'ideal')."""
    value = default(name)
    return '%g' % value if isinstance(value, float) else str(value)
