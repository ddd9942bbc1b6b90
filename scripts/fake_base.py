#!/usr/bin/env -S --block-signal=SIGINT /usr/bin/python3
"""A kinematic robot base for the demo: cmd_vel in, odom and tf out (fake_base)."""
from battery_simulator.ros1.fake_base import main

main()
