#!/bin/bash
# Set up, build and run the simulator: roslaunch battery_simulator sim.launch [arg:=value ...]
# (LAUNCH_FILE=demo.launch runs another of the package's launch files the same way.)
# Ctrl-C stops it.
set -eo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
"$root/tools/build.sh"
export PATH="/usr/bin:$PATH"
source "$root/build/devel/setup.bash"
exec roslaunch battery_simulator "${LAUNCH_FILE:-sim.launch}" "$@"
