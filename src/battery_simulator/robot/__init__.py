"""The robot's loop without ROS: the cut-off gate's rule, contact from a pose, the patrol-and-dock phases,
the clock's tick policy, the kinematic base (each front end adapts them: ros1/, ros2/)."""
