"""battery_simulator: a simulated robot battery for ROS 1 and ROS 2.

Who each subpackage serves:
  - ``core``: the ROS-free battery model, pack, gauge, parameters, replay, prediction and fit;
  - ``ros1``: the rospy front end (action server, BatteryState publisher, fleet host, robot nodes);
  - ``ros2``: the rclpy front end, with the same module and class names for the same job;
  - ``robot``: the demo robot's rules without ROS (cut-off gate, dock contact, patrol and dock);
  - ``web``: the dashboard's pages and rules;
  - ``cli``: the command-line programs (action client, plotter, fit).
"""
