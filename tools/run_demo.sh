#!/bin/bash
# Set up, build and run the demo: roslaunch battery_simulator demo.launch [arg:=value ...]
# A robot patrols, docks when its battery is low, charges, and patrols again. Ctrl-C stops it.
set -eo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
"$root/tools/build.sh"
export PATH="/usr/bin:$PATH"
source "$root/build/devel/setup.bash"
exec roslaunch battery_simulator demo.launch "$@"
