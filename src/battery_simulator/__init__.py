"""battery_simulator: a simulated robot battery for ROS 1.

The battery model (``battery_model``, ``parameters``, ``replay``) imports no
rospy; the ROS nodes (``action_server``, ``state_publisher``, ``client``) wrap it.
"""
