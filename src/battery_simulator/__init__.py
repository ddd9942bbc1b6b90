"""battery_simulator: a simulated robot battery for ROS 1.

``battery_simulator.core`` is the ROS-free battery model (``battery_model``,
``parameters``, ``replay``, ``measured_data``); ``battery_simulator.nodes``
holds the ROS nodes that wrap it and what they share.
"""
