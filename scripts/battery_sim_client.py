#!/usr/bin/python3
"""Sends a charge (1) or discharge (0) goal to battery_simulator and shows progress."""
from battery_simulator.cli.client_cli import main

main()
