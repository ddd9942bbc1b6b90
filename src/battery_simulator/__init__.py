"""battery_simulator: a simulated robot battery for ROS 1.

Who each subpackage serves:
  - ``core``: the ROS-free battery model, parameters, replay and measured data;
  - ``battery``: the battery's ROS side (action server, BatteryState publisher);
  - ``robot``: the demo robot (kinematic base, dock contact, cut-off gate, patrol);
  - ``cli``: the command-line programs (action client, plotter);
  - ``ros``: what every node shares (the interface's names, start-up checks).
"""
