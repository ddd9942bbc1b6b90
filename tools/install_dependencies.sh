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
if [ ${#missing[@]} -eq 0 ]; then
  echo "install_dependencies: all ${#packages[@]} packages present"
  exit 0
fi

sudo=""
[ "$(id -u)" -eq 0 ] || sudo=sudo
echo "install_dependencies: installing ${missing[*]}"
$sudo apt-get update -qq
DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
echo "install_dependencies: done"
