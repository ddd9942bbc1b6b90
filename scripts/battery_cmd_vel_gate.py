#!/usr/bin/env -S --block-signal=SIGINT /usr/bin/python3
"""Relays cmd_vel while the battery can supply the motors (battery_cmd_vel_gate)."""
from battery_simulator.ros1.cmd_vel_gate import main

main()
