"""``battery_sim`` (ROS 2): one battery in one process, the two roles of sim.launch.

    ros2 run battery_simulator battery_sim [--ros-args -r __ns:=/robot1 -p time_scale:=100 ...]

Nodes ``battery_simulator`` (the model, the action ``battery_simulator``, the
services, ``cmd_vel``, ``charger_contact``, the ``charging`` parameter and the
live settings) and ``battery_state_pub`` (``battery_status``, ``battery_low``,
``battery_critical``, ``/diagnostics``). docs/ros2.md lists every name.

:Parameters of battery_simulator:
  - ``config`` (str, read-only): battery YAML (default: the package's config/battery.yaml)
  - ``time_scale`` (float > 0, live): simulated seconds per wall second (default 22; ignored under use_sim_time)
  - ``update_rate`` (float, Hz, read-only): model updates per second (default 10)
  - ``initial_percentage`` (float 0-100, read-only): charge at start (default 100)
  - ``state_file`` (str, read-only): JSON file the state is saved to and resumed from
  - ``charging`` (bool, live): the mode; a goal writes it
  - ``load_current_a``, ``load_power_w``, ``charge_current_a``, ``ambient_temperature_c``,
    ``drive_power_w_per_mps``, ``turn_power_w_per_radps`` (float, live): override the config
:Parameters of battery_state_pub:
  - ``rate``, ``frame_id``, ``stale_timeout``, ``low_percentage``, ``critical_percentage``, ``hysteresis``
"""
import rclpy
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node

from battery_simulator.ros2.battery_node import OneBattery
from battery_simulator.ros2.startup import StartupError, ending_quietly, exit_on_startup_error, spin


def main(args=None):
    with ending_quietly():
        rclpy.init(args=args)
        battery_node = Node('battery_simulator')
        status_node = Node('battery_state_pub')
        try:
            one = OneBattery(battery_node, status_node)
        except StartupError as error:
            exit_on_startup_error(error, battery_node.get_logger())
        executor = SingleThreadedExecutor()
        executor.add_node(battery_node)
        executor.add_node(status_node)
        one.report_ready()
        try:
            spin(executor)
        finally:
            one.front.finish()


if __name__ == "__main__":
    main()
