#!/usr/bin/python3
"""Reports charger contact while the robot stands on its dock (battery_dock_contact)."""
from battery_simulator.robot.dock_contact import main

main()
