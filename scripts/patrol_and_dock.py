#!/usr/bin/env -S --block-signal=SIGINT /usr/bin/python3
"""The demo behaviour: patrol, dock when low, charge, undock (patrol_and_dock)."""
from battery_simulator.ros1.patrol_and_dock import main

main()
