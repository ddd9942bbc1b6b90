#!/bin/bash
# Build, source the devel space and print both benchmark tables: the model and the running ROS graph.
set -eo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
export PATH="/usr/bin:$PATH"
"$root/tools/build.sh" >/dev/null
source "$root/build/devel/setup.bash"
exec /usr/bin/python3 "$root/tools/benchmark.py" --graph "$@"
