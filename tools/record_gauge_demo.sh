#!/bin/bash
# Record one demo cycle with gauge:=realistic (speed 240) into docs/demo_gauge.bag and plot what the
# robot read against the truth into docs/demo_gauge.png (about a minute). Its own master on a free
# port; every process it starts is ended by its pid.
set -eo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
export PATH="/usr/bin:$PATH"
"$root/tools/build.sh" >/dev/null
source "$root/build/devel/setup.bash"
port=$(/usr/bin/python3 -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])')
export ROS_MASTER_URI=http://127.0.0.1:$port
work=$(mktemp -d)
roslaunch -p "$port" battery_simulator demo.launch gauge:=realistic speed:=240 "$@" > "$work/demo.log" 2>&1 & demo=$!
trap 'kill -INT $recorder $demo 2>/dev/null; wait $demo 2>/dev/null; rm -rf "$work"' EXIT
until rostopic list >/dev/null 2>&1; do sleep 0.2; done
rosbag record -O "$work/demo_gauge.bag" /battery_status /battery_simulator/state /patrol_and_dock/phase \
  __name:=gauge_recorder > /dev/null 2>&1 & recorder=$!
until [ "$(grep -c 'phase [A-Z_]* at' "$work/demo.log")" -ge 5 ]; do sleep 0.5; done
sleep 2
rosnode kill /gauge_recorder > /dev/null
for _ in $(seq 100); do [ -f "$work/demo_gauge.bag" ] && break; sleep 0.1; done
wait $recorder || true
grep 'phase [A-Z_]* at' "$work/demo.log" | sed 's/.*\]: //'
cp "$work/demo_gauge.bag" "$root/docs/demo_gauge.bag"
/usr/bin/python3 "$root/tools/plot_gauge.py" "$root/docs/demo_gauge.bag" -o "$root/docs/demo_gauge.png" \
  --title 'demo.launch gauge:=realistic (speed 240): what the robot read against the truth'
