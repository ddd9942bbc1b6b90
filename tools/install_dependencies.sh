#!/bin/bash
# Install what battery_simulator needs from the distribution's own archive
# (Debian 12: ROS 1 as ordinary packages). Idempotent: when
# everything is installed it only checks, in about a second.
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
mapfile -t packages < <(grep -v '^#' "$here/debian-dependencies.txt" | awk 'NF > 1 {for (i = 2; i <= NF; i++) print $i}' | sort -u)

missing=()
for package in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$package" 2>/dev/null | grep -q 'install ok installed' || missing+=("$package")
done
# What Debian does not package (rosbags for battery_fit): from PyPI into build/python_deps, again
# only when tools/python_requirements.txt has changed.
python_deps() {
  local target="$here/build/python_deps" wanted
  wanted=$(sha1sum "$here/tools/python_requirements.txt" | cut -c1-40)
  [ -f "$target/.requirements" ] && [ "$(cat "$target/.requirements")" = "$wanted" ] && return
  echo "install_dependencies: pip install --target build/python_deps (tools/python_requirements.txt)"
  rm -rf "$target"
  /usr/bin/python3 -m pip install -q --disable-pip-version-check --no-deps --target "$target" \
    -r "$here/tools/python_requirements.txt"
  echo "$wanted" >"$target/.requirements"
}

if [ ${#missing[@]} -eq 0 ]; then
  echo "install_dependencies: all ${#packages[@]} packages present"
  python_deps
  exit 0
fi

sudo=""
[ "$(id -u)" -eq 0 ] || sudo=sudo
echo "install_dependencies: installing ${missing[*]}"
$sudo apt-get update -qq
DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
python_deps
echo "install_dependencies: done"
