"""One battery in a node of its own (battery_sim's; ros2/one_battery.py's twin): its BatterySimServer around a
core Battery built by ros1/battery_settings.py, its update loop and its saved state. On ROS 1 its
battery_state_pub is another process (battery_state_pub.py), following the server's state topic.

:ROS Parameters: core/node_settings.py BATTERY_SETTINGS as private parameters (``~config``, ``~time_scale``,
  ``~update_rate``, ``~initial_percentage``, ``~charging``, ``~state_file``, ``~max_time_jump``), listed with
  the topics and services in ros1/action_server.py; ``~saved_state``, written by the node (ros1/saved_state.py).
"""
import rospy

from battery_simulator.ros1.action_server import BatterySimServer
from battery_simulator.ros1.battery_settings import ros_battery
from battery_simulator.ros1.log import RobotLog
from battery_simulator.ros1.saved_state import StateStore
from battery_simulator.ros1.workers import StatusTimer, UpdateLoop


class OneBattery:
    """The battery of this node's namespace, from ``settings`` (read_battery_settings)."""

    def __init__(self, settings):
        namespace = rospy.get_namespace()
        self.log = RobotLog(progress=True)
        self.loop = UpdateLoop(settings['update_rate'])
        store = StateStore(rospy.resolve_name('~saved_state'), settings['state_file'])
        battery = ros_battery(settings['params'], settings, settings['charging'], namespace, self.log)
        self.front = BatterySimServer(namespace, rospy.get_name(), battery, store, self.loop, StatusTimer(),
                                      self.log)

    def start(self):
        rospy.on_shutdown(self.loop.stop)   # client hooks run before rospy closes the topics
        self.loop.start()     # first: dynamic_reconfigure's first callback waits for an update
        self.front.start()

    def report_ready(self):
        self.front.report_ready()

    def finish(self):
        """At the end: the loop stopped, so the server has preempted its goal and saved its state."""
        self.loop.stop()
