#!/bin/bash
# Set up, build and run every test: the masterless unit tests (pytest), the
# rostests and the catkin workspace test (ROS 1), the rclpy tests (ROS 2), then print one summary line.
# Exits non-zero if anything failed or if no test ran.
set -eo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
export PATH="/usr/bin:$PATH"
# One BLAS thread per process: ctest runs four tests at once on this machine's two cores, and BLAS's own
# threads only spin against them (the battery_fit tests: 70 s of CPU, 26 of it system time, against 42 s
# with one thread, in the same wall time)
export OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1
"$root/tools/build.sh"
"$root/tools/ros2.sh" true   # the ROS 2 environment, set up once before the tests (about a minute the first time)
cmake -S "$root" -B "$root/build" -Dbattery_simulator_WORKSPACE_TEST=ON -Dbattery_simulator_ROS2_TEST=ON >/dev/null
source "$root/build/devel/setup.bash"
rm -rf "$root/build/test_results/battery_simulator"
status=0
(cd "$root/build" && ctest -j4 --output-on-failure --timeout 900) || status=$?
/usr/bin/python3 "$root/tools/summarize_test_results.py" "$root/build/test_results/battery_simulator" || status=1
exit $status
