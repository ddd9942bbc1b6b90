#!/usr/bin/python3
"""Replays a CSV load profile through the battery model (no ROS needed)."""
from battery_simulator.core.replay import main

main()
