#!/usr/bin/env -S --block-signal=SIGINT /usr/bin/python3
"""The battery_simulator action server node (BatterySimServer)."""
from battery_simulator.ros1.battery_sim import main

main()
