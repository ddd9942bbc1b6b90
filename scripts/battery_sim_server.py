#!/usr/bin/python3
"""The battery_simulator action server node (BatterySimServer)."""
from battery_simulator.battery.action_server import main

main()
