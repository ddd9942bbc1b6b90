#!/usr/bin/python3
"""Plots a battery run (replay CSV or rosbag of battery_status) into a PNG."""
from battery_simulator.cli.plot import main

main()
