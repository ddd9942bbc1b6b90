#!/usr/bin/env -S --block-signal=SIGINT /usr/bin/python3
"""Many simulated batteries in one process (battery_fleet)."""
from battery_simulator.ros1.fleet_host import main

main()
