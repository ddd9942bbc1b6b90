"""The rclpy front end (ROS 2): thin adapters around core/battery.py, as battery/ is for rospy."""
