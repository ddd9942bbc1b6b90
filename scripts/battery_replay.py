#!/usr/bin/python3
"""Replays a CSV load profile through the battery model (no ROS needed)."""
from battery_simulator.replay import main

main()
