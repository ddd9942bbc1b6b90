#!/bin/bash
# Record one demo cycle at demo.launch's defaults into docs/demo_cycle.bag and plot it into
# docs/demo_cycle.png (about two and a half minutes). Its own master on a free port; every
# process it starts is ended by its pid.
set -eo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
export PATH="/usr/bin:$PATH"
"$root/tools/build.sh" >/dev/null
source "$root/build/devel/setup.bash"
port=$(/usr/bin/python3 -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])')
export ROS_MASTER_URI=http://127.0.0.1:$port
work=$(mktemp -d)
roslaunch -p "$port" battery_simulator demo.launch > "$work/demo.log" 2>&1 & demo=$!
trap 'kill -INT $recorder $demo 2>/dev/null; wait $demo 2>/dev/null; rm -rf "$work"' EXIT
until rostopic list >/dev/null 2>&1; do sleep 0.2; done
rosbag record -O "$work/demo_cycle.bag" /battery_status /battery_low /battery_critical \
  /patrol_and_dock/phase __name:=demo_recorder > /dev/null 2>&1 & recorder=$!
# one whole cycle: PATROL, GO_TO_DOCK, CHARGING, UNDOCK, PATROL
until [ "$(grep -c 'phase [A-Z_]* at' "$work/demo.log")" -ge 5 ]; do sleep 0.5; done
sleep 2   # a little of the second patrol
rosnode kill /demo_recorder > /dev/null   # asks our recorder node to stop: it closes the bag
for _ in $(seq 100); do [ -f "$work/demo_cycle.bag" ] && break; sleep 0.1; done
wait $recorder || true
grep 'phase [A-Z_]* at' "$work/demo.log" | sed 's/.*\]: //'
cp "$work/demo_cycle.bag" "$root/docs/demo_cycle.bag"
rosrun battery_simulator battery_plot.py "$root/docs/demo_cycle.bag" -o "$root/docs/demo_cycle.png" \
  --title 'demo.launch at its defaults (speed 60): patrol, low at 25 %, dock, charge (CC then CV), undock, patrol'
