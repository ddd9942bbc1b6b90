"""Names the nodes share (all relative, so a robot namespace moves them all)."""

#: the mode parameter: 1/true charges, 0/false discharges, unset holds
MODE_PARAM = 'MyRobot/BatteryStatus'
#: ROS 2's mode parameter of the battery_simulator node (the same values: true / false, 1 / 0)
CHARGING_PARAM = 'charging'
#: the node names of sim.launch's two roles (ROS 1 names the server BatterySimServer in the launch file)
BATTERY_NODE = 'battery_simulator'
STATUS_NODE = 'battery_state_pub'
#: the action (battery_simulator/battery_simAction)
ACTION = 'battery_simulator'
#: the server's state after every update (battery_simulator/BatterySimState)
STATE_TOPIC = 'battery_simulator/state'
#: std_msgs/UInt64 from battery_state_pub: the publish_now update it has sent on battery_status
STATUS_SENT = 'battery_simulator/status_sent'
#: sensor_msgs/BatteryState, published by battery_state_pub
BATTERY_STATUS = 'battery_status'
#: the same BatteryState under the name opennav_docking reads (battery_state_pub's ``battery_state_topic``)
BATTERY_STATE = 'battery_state'
BATTERY_LOW = 'battery_low'
BATTERY_CRITICAL = 'battery_critical'
CMD_VEL = 'cmd_vel'
CHARGER_CONTACT = 'charger_contact'
ODOM = 'odom'
#: the cut-off gate's input and output (demo.launch remaps them: cmd_vel_nav -> gate -> cmd_vel)
CMD_VEL_IN = 'cmd_vel_in'
CMD_VEL_OUT = 'cmd_vel_out'
#: patrol_and_dock's phase (std_msgs/String, latched)
PHASE = 'patrol_and_dock/phase'
#: the global topics: simulated time (sim_clock), the REP-107 diagnostics, ROS 2's battery claims (Part 3)
CLOCK = '/clock'
DIAGNOSTICS = '/diagnostics'
BATTERY_CLAIMS = '/battery_claims'
SET_LOAD = 'battery_simulator/set_load'
SET_CHARGING = 'battery_simulator/set_charging'
SET_STATE = 'battery_simulator/set_state'
RESET = 'battery_simulator/reset'
INJECT_FAULT = 'battery_simulator/inject_fault'
PREDICT = 'battery_simulator/predict'


def robot_topic(namespace, name):
    """``name`` under a robot's ``namespace`` ('' or '/robot1/', as the nodes hold it); an absolute name stays."""
    return name if name.startswith('/') else namespace + name
