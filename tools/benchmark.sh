#!/bin/bash
# Build, source the devel space and print both benchmark tables: the model and the running ROS graph.
# tools/benchmark.sh ros2 [N ...]: the ROS 2 section (tools/ros2_benchmark.py) instead.
set -eo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
export PATH="/usr/bin:$PATH"
if [ "$1" = ros2 ]; then   # the ROS 2 section: one battery, and the fleet host at N = 10, 100, 250
  shift
  exec "$root/tools/ros2.sh" python3 "$root/tools/ros2_benchmark.py" "$@"
fi
"$root/tools/build.sh" >/dev/null
source "$root/build/devel/setup.bash"
exec /usr/bin/python3 "$root/tools/benchmark.py" --graph "$@"
