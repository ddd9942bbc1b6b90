"""The ROS side: the nodes that wrap the core model (action server, BatteryState
publisher, client, dock contact, cmd_vel gate, demo base and patrol) and the
small modules they share (topic names, start-up parameter checks, message mapping)."""
