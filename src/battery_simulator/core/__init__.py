"""The ROS-free core: the battery model, its parameters, profile replay and
the measured cell data it is validated against. Nothing here imports rospy
or a message type, so it runs and is tested without ROS."""
