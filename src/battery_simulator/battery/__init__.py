"""The battery's ROS side: the action server, the BatteryState publisher and what they share."""
