#!/usr/bin/env -S --block-signal=SIGINT /usr/bin/python3
"""The sensor_msgs/BatteryState publisher node (battery_state_pub)."""
from battery_simulator.ros1.battery_state_pub import main

main()
