"""battery_state_pub's main on ROS 1 (scripts/battery_state_pub.py): one BatteryStatePublisher
(state_publisher.py) following the server's state topic of its namespace; ros2/battery_state_pub.py's twin."""
import rospy

from battery_simulator.ros1.battery_settings import read_publisher_settings
from battery_simulator.ros1.startup import init_node, signals_held
from battery_simulator.ros1.state_publisher import BatteryStatePublisher, publish_at_rate
from battery_simulator.ros1.workers import ChangeLoop, DiagnosticsLoop


def main():
    with signals_held():
        settings = init_node('battery_state_pub', read_publisher_settings)
        changes = ChangeLoop()
        publisher = BatteryStatePublisher(rospy.get_namespace(), rospy.get_name(), changes=changes, **settings)
        publisher.follow_topic()
        changes.start()
        DiagnosticsLoop([publisher]).start()
    publish_at_rate([publisher], publisher.rate)
