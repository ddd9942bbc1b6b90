#!/usr/bin/env -S --block-signal=SIGINT /usr/bin/python3
"""Reports charger contact while the robot stands on its dock (battery_dock_contact)."""
from battery_simulator.ros1.dock_contact import main

main()
