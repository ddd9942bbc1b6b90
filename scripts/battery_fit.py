#!/usr/bin/python3
"""Fits a battery config to recorded logs of your robot (no ROS needed)."""
from battery_simulator.cli.fit import main

main()
