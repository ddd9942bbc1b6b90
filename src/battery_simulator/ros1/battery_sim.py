"""battery_sim's main on ROS 1 (scripts/battery_sim_server.py, BatterySimServer in sim.launch): one battery
(one_battery.py) in a node of its own; ros2/battery_sim.py's twin."""
import rospy

from battery_simulator.ros1.battery_settings import read_battery_settings
from battery_simulator.ros1.one_battery import OneBattery
from battery_simulator.ros1.startup import (StartupError, check_one_battery_per_name, exit_on_startup_error, init_node,
                                            signals_held, wait_for_rosout)


def main():
    with signals_held():
        settings = init_node('BatterySimServer', read_battery_settings)
        try:
            check_one_battery_per_name([rospy.get_namespace()])
        except StartupError as error:
            exit_on_startup_error(error)
        one = OneBattery(settings)
        one.start()
        wait_for_rosout()
        one.report_ready()
    rospy.spin()
    one.finish()
