#!/usr/bin/env -S --block-signal=SIGINT /usr/bin/python3
"""The live dashboard: every battery on the master in a browser (battery_dashboard)."""
from battery_simulator.ros1.dashboard import main

main()
