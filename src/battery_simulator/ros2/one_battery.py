"""One battery in a process of its own (battery_sim's, a lone battery_state_pub's, the demo's; ros1/one_battery.py's
twin): its BatterySimServer around a core Battery built by ros2/battery_settings.py, its state_file, and its
battery_state_pub role (on ROS 2 the same process: the state goes to the publisher without a message)."""
from battery_simulator.core import ros_names
from battery_simulator.core.resume_rule import resume_battery, say_ready
from battery_simulator.core.node_settings import GAUGE_CONFIG
from battery_simulator.ros2 import prediction_service
from battery_simulator.ros2.action_server import BatterySimServer
from battery_simulator.ros2.battery_settings import (STARTUP_SETTINGS, TIME_SCALE, check_state_path, declare_live,
                                                     declare_mode, load_config, make_battery, read_publisher_settings)
from battery_simulator.ros2.log import RobotLog
from battery_simulator.ros2.saved_state import state_store
from battery_simulator.ros2.startup import declare_settings, steady_clock
from battery_simulator.ros2.state_publisher import BatteryStatePublisher, publish_diagnostics


class OneBattery:
    """One battery on ``battery_node`` (action, services, parameters) and ``status_node`` (battery_status,
    low/critical, diagnostics): battery_sim's two nodes, or a lone battery_state_pub's one."""

    def __init__(self, battery_node, status_node):
        self.log = RobotLog(battery_node.get_logger(), progress=True)
        self.settings = settings = declare_settings(battery_node, STARTUP_SETTINGS + (TIME_SCALE, GAUGE_CONFIG))
        charging = declare_mode(battery_node)
        publisher = read_publisher_settings(status_node)
        params = load_config(battery_node, settings['config'], settings['gauge_config'])
        check_state_path(battery_node, settings['state_file'])
        self.battery = make_battery(battery_node, settings, params, charging, self.log)
        declare_live(battery_node, self.battery)
        self.store = state_store(settings['state_file'], self.log.warn)
        self.resumed = resume_battery(self.battery, self.store.load(), self.store.where, self.log)
        self.status = BatteryStatePublisher(status_node, '', status_node.get_fully_qualified_name().lstrip('/'),
                                            log=RobotLog(status_node.get_logger()), **publisher)
        self.front = BatterySimServer(battery_node, self.battery, '', self.log, self.status, self.store)
        prediction_service.start_workers()
        battery_node.add_on_set_parameters_callback(self.front.on_set_parameters)
        battery_node.create_timer(1.0 / settings['update_rate'], self.front.update, clock=steady_clock())
        status_node.create_timer(1.0 / publisher['rate'], self.status.publish_once, clock=steady_clock())
        publish_diagnostics(status_node, [self.status])
        self.front.update()

    def report_ready(self):
        say_ready(self.battery, self.log, self.resumed)

    def finish(self):
        """At a stop signal: the goal ended and the state saved; predict's workers ended. Returns a function
        telling whether the goal's result has been sent (ros2/startup.py run)."""
        finished = self.front.finish()
        prediction_service.stop_workers()
        return finished


def status_node_name(battery_node):
    """battery_state_pub, beside the battery node in its namespace whatever ``-r __node:=`` renamed the battery
    node to (a global remap would rename both to one name); never the battery node's own name."""
    status = ros_names.STATUS_NODE
    return status if battery_node.get_name() != status else status + '_status'
