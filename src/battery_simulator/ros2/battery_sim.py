"""``battery_sim``'s main on ROS 2: one battery in one process, the two roles of sim.launch (one_battery.py;
ros1/battery_sim.py's twin, whose battery_state_pub is a process of its own).

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
  - ``state_file`` (str, read-only): JSON file the state is saved to and resumed from (a file that exists
    and is not a state file, or a path that cannot be written, stops the node at start with one line)
  - ``charging`` (bool, or 1 / 0, live): the mode; a goal writes it
  - ``load_current_a``, ``load_power_w``, ``charge_current_a``, ``ambient_temperature_c``,
    ``drive_power_w_per_mps``, ``turn_power_w_per_radps`` (float, live): override the config
:Parameters of battery_state_pub:
  - ``rate``, ``frame_id``, ``stale_timeout``, ``low_percentage``, ``critical_percentage``, ``hysteresis``
"""
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node

from battery_simulator.core import ros_names
from battery_simulator.ros2.battery_claims import BatteryClaim
from battery_simulator.ros2.one_battery import OneBattery, status_node_name
from battery_simulator.ros2.startup import (StartupError, ending_quietly, exit_on_startup_error,
                                            explain_parameter_refusals, init, own_node, run)


def main(args=None):
    with ending_quietly():
        init(args)
        battery_node = Node(ros_names.BATTERY_NODE)
        status_node = own_node(status_node_name(battery_node), battery_node.get_namespace())
        executor = SingleThreadedExecutor()
        executor.add_node(battery_node)
        executor.add_node(status_node)
        for node in (battery_node, status_node):
            explain_parameter_refusals(node)
        claim = BatteryClaim(battery_node, [battery_node.get_namespace()],
                             battery_node.get_fully_qualified_name())
        try:
            claim.wait(executor)
            one = OneBattery(battery_node, status_node)
        except StartupError as error:
            exit_on_startup_error(error, battery_node.get_logger())
        one.report_ready()
        run(executor, one.finish, claim)


if __name__ == "__main__":
    main()
