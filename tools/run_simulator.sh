#!/bin/bash
# Set up, build and run the simulator: roslaunch battery_simulator sim.launch [arg:=value ...]
# (LAUNCH_FILE=demo.launch runs another of the package's launch files the same way.)
# Ctrl-C stops it.
set -eo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
"$root/tools/build.sh"
export PATH="/usr/bin:$PATH"
source "$root/build/devel/setup.bash"
if [ -z "${LAUNCH_FILE:-}" ]; then
    echo "run_simulator: the battery publishes sensor_msgs/BatteryState on /battery_status. In another terminal:"
    echo "  source $root/build/devel/setup.bash"
    echo "  rostopic echo /battery_status                        # what a robot reads"
    echo "  rosrun battery_simulator battery_sim_client.py 1     # charge it to Full (0: discharge)"
fi
exec roslaunch battery_simulator "${LAUNCH_FILE:-sim.launch}" "$@"
