#!/bin/bash
# Set up, build and run the demo: roslaunch battery_simulator demo.launch [arg:=value ...]
# A robot patrols, docks when its battery is low, charges, and patrols again. Ctrl-C stops it.
LAUNCH_FILE=demo.launch exec "$(dirname "$0")/run_simulator.sh" "$@"
