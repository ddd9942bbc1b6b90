#!/bin/bash
# Build the package out of tree in build/ with Debian's Python (sourced by the other tools).
set -euo pipefail
export PATH="/usr/bin:$PATH"
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
"$root/tools/install_dependencies.sh"
cmake -S "$root" -B "$root/build" -DPYTHON_EXECUTABLE=/usr/bin/python3 -DCATKIN_ENABLE_TESTING=ON >"$root/build.log" 2>&1 \
  && cmake --build "$root/build" -- -j2 >>"$root/build.log" 2>&1 \
  || { cat "$root/build.log"; echo "build failed (log: build.log)"; exit 1; }
echo "build: ok (devel space: build/devel)"
