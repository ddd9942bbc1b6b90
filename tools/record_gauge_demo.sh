#!/bin/bash
# Record CYCLES demo cycles (default 4) with gauge:=realistic (speed 240) and plot what the robot read against
# the truth, the cells, the cut-off and the phases into docs/demo_gauge.png (about 3 minutes); print each
# cycle's figures (the steady state of docs/robot_loop.md). Usage: tools/record_gauge_demo.sh [CYCLES]
# [demo.launch arguments...]. Its own master on a free port (or PORT=11429, a port of your own); every
# process it starts is ended by its pid. The bag stays in a temporary folder (removed at the end) unless
# KEEP_BAG=path is set (docs/demo_gauge.bag is one, test_plot.py reads it). A demo that does not start within 60 s, or does not
# finish its cycles within 5 minutes a cycle, ends the script with its log's last lines.
set -eo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
cycles=4
if [[ "$1" =~ ^[0-9]+$ ]]; then cycles=$1; shift; fi
export PATH="/usr/bin:$PATH"
"$root/tools/build.sh" >/dev/null
source "$root/build/devel/setup.bash"
port=${PORT:-$(/usr/bin/python3 -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])')}
if [[ ! "$port" =~ ^[0-9]+$ ]] || (( port < 1024 || port > 65535 )); then
  echo "record_gauge_demo.sh: PORT=$port is invalid: must be a port number in [1024, 65535]" >&2; exit 2
fi
export ROS_MASTER_URI=http://127.0.0.1:$port
work=$(mktemp -d)
roslaunch -p "$port" battery_simulator demo.launch gauge:=realistic speed:=240 "$@" > "$work/demo.log" 2>&1 & demo=$!
trap 'kill -INT $recorder $demo 2>/dev/null; wait $demo 2>/dev/null; rm -rf "$work"' EXIT
# wait_for SECONDS WHAT COMMAND...: until COMMAND succeeds; past SECONDS, the demo log's end and exit 1
wait_for() {
  local limit=$(($(date +%s) + $1)) what=$2; shift 2
  until "$@"; do
    if (( $(date +%s) > limit )) || ! kill -0 $demo 2>/dev/null; then
      echo "record_gauge_demo.sh: $what did not happen (demo.launch's log ends:)" >&2
      tail -n 20 "$work/demo.log" >&2; exit 1
    fi
    sleep 0.5
  done
}
master_up() { rostopic list >/dev/null 2>&1; }
phases_seen() { [ "$(grep -c 'phase [A-Z_]* at' "$work/demo.log")" -ge $((4 * cycles + 1)) ]; }
wait_for 60 "the master on port $port" master_up
rosbag record -O "$work/demo_gauge.bag" /battery_status /battery_simulator/state /patrol_and_dock/phase \
  /battery_low /battery_critical __name:=gauge_recorder > /dev/null 2>&1 & recorder=$!
# a cycle is PATROL, GO_TO_DOCK, CHARGING, UNDOCK; end at the PATROL after the last cycle's UNDOCK
wait_for $((300 * cycles)) "$cycles cycles" phases_seen
sleep 2
rosnode kill /gauge_recorder > /dev/null
for _ in $(seq 100); do [ -f "$work/demo_gauge.bag" ] && break; sleep 0.1; done
wait $recorder || true
grep 'phase [A-Z_]* at' "$work/demo.log" | sed 's/.*\]: //'
/usr/bin/python3 - "$work/demo_gauge.bag" <<'EOF'
"""Each cycle's figures: where the robot read low and docked (read and true), and how the charge ended."""
import sys

import rosbag

read, truth, phases = [], [], []
with rosbag.Bag(sys.argv[1]) as bag:
    for topic, msg, stamp in bag.read_messages():
        if topic == '/battery_status':
            read.append((msg.header.stamp.to_sec(), 100.0 * msg.percentage, msg.current, msg.power_supply_status))
        elif topic == '/battery_simulator/state':
            truth.append((msg.battery.header.stamp.to_sec(), msg.true_percentage))
        elif topic == '/patrol_and_dock/phase':
            phases.append((stamp.to_sec(), msg.data))


def at(series, t):
    """The value of a (t, value, ...) series at time t (the last sample at or before it)."""
    last = series[0]
    for sample in series:
        if sample[0] > t:
            break
        last = sample
    return last


FULL = 4
for (t0, p0), (t1, p1) in zip(phases, phases[1:]):
    if p1 == 'CHARGING':   # docked
        dock = t1
        print('docked: read %.1f %%, true %.1f %%' % (at(read, dock)[1], at(truth, dock)[1]))
    if p0 == 'CHARGING':   # the charge from t0 to t1
        charge = [r for r in read if t0 <= r[0] <= t1]
        full = next((r for r in charge if r[3] == FULL), None)
        held = next((r for r in charge if r[1] >= 98.95), None)   # HOLD_BEFORE_FULL: 99 % until Full
        pinned = next((r for r in charge if r[1] >= 99.95), None)
        if held is not None and full is not None and pinned is not None:
            last = [r for r in charge if r[0] < full[0]][-1]   # the taper's last current before Full
            print('  read 99 %% from true %.1f %%, %.0f s before Full (%.2f A, falling to %.2f A); 100 %% %.0f s '
                  'before Full; Full at true %.1f %%' % (at(truth, held[0])[1], full[0] - held[0], held[2], last[2],
                                                         full[0] - pinned[0], at(truth, full[0])[1]))
EOF
if [ -n "$KEEP_BAG" ]; then   # bz2-compressed (4 cycles: 1.6 MB, not 13 MB); rosbag reads it as it is
  mkdir "$work/kept" && rosbag compress -q --bz2 --output-dir "$work/kept" "$work/demo_gauge.bag"
  cp "$work/kept/demo_gauge.bag" "$KEEP_BAG"
fi
rosrun battery_simulator battery_plot.py "$work/demo_gauge.bag" -o "$root/docs/demo_gauge.png" --low 0.25 \
  --config "$root/config/battery_realistic.yaml" \
  --title "demo.launch gauge:=realistic (speed 240), $cycles cycles: what the robot read against the truth"
