#!/usr/bin/env -S --block-signal=SIGINT /usr/bin/python3
"""Publishes /clock running ~speed times as fast as wall time (sim_clock)."""
from battery_simulator.ros1.sim_clock import main

main()
