#!/usr/bin/python3
"""battery_doctor.py: what a live ROS 1 graph of batteries and their consumers gets wrong."""
from battery_simulator.ros1.doctor import main

main()
