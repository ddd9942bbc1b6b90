#!/bin/bash
# tools/netns_fleet.sh [--ros 1|2] [--hosts 3] [--robots 250] [--resume] [--measure SECONDS] [--timeout SECONDS]
#                      [--time-scale 22] [--logs DIR]
#
# A fleet spread over several hosts, proven on one machine: Linux network namespaces stand for the
# machines. It makes one namespace per fleet host, one for the observer and one holding only the bridge
# that joins them (private addresses 10.200.0.0/24, no default route, no uplink: the root namespace gets
# no interface, so nothing can leave this machine), runs `--robots` robots in each host (robot0 ...
# robot<hosts x robots - 1>, the same names whatever the split), and in the observer namespace:
#   --ros 2: the Fast DDS discovery server (every process a client of it: ROS_DISCOVERY_SERVER; UDPv4
#            only, since shared memory would go round the bridge) and the observer as a super client;
#   --ros 1: roscore (the one master) and the observer; every host has ROS_MASTER_URI and its own ROS_IP.
# The observer subscribes to every robot's battery_status (tools/netns_fleet_observer.py). It prints
#   seen N of M robots from the observer host in T s          (T: since the hosts were started)
# and, when asked:
#   --measure S: each robot's rate over S s, and the CPU and memory of the server (or master) and hosts;
#   --resume:    host 1 is killed with SIGKILL and started again; every robot of it must resume within 1 %.
# --time-scale: every robot's (fleet.launch's default, 22); --logs DIR: every process's log copied there at the end.
# Then it ends every process it started (by pid) and deletes the namespaces, on every way out.
# Exit: 0 when every robot was seen (and, with --resume, resumed within 1 %), 1 otherwise, 2 on a bad
# argument or a refused start, 77 when namespaces cannot be made here (not root, no `ip netns`).
#
# tools/netns_fleet.sh --run-in NAMESPACE -- COMMAND...: the guard alone: runs COMMAND in NAMESPACE
# unless it is the root namespace (this shell's) or has a default route (then exit 2, one line).
set -eo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
export PATH="/usr/bin:$PATH"
SUBNET=10.200.0
OBSERVER_IP=$SUBNET.1
DISCOVERY_PORT=11811
MASTER_PORT=11311

say() { echo "netns_fleet: $*" >&2; }
usage() { say "usage: tools/netns_fleet.sh [--ros 1|2] [--hosts N] [--robots N] [--resume] [--measure S] [--timeout S]"; exit 2; }

# The guard of every process the tool starts: a named namespace of its own, with no default route.
refuse_unless_fenced() {
  local ns=$1
  ip netns list | awk '{print $1}' | grep -qx -- "$ns" || { say "refused: no network namespace '$ns'"; return 2; }
  if [ "$(ip netns exec "$ns" readlink /proc/self/ns/net)" = "$(readlink /proc/$$/ns/net)" ]; then
    say "refused: '$ns' is this shell's (root) network namespace"; return 2
  fi
  if [ -n "$(ip -n "$ns" -4 route show default)$(ip -n "$ns" -6 route show default)" ]; then
    say "refused to start a process in namespace '$ns': it has a default route (traffic could leave this machine)"
    return 2
  fi
}

if [ "$1" = --run-in ]; then
  ns=$2; shift 2; [ "$1" = -- ] && shift
  [ -n "$ns" ] && [ $# -gt 0 ] || usage
  refuse_unless_fenced "$ns" || exit 2
  exec ip netns exec "$ns" "$@"
fi

ros=2 hosts=3 robots=250 resume=0 measure=0 timeout=180 time_scale=22 logs=
while [ $# -gt 0 ]; do
  case $1 in
    --ros) ros=$2; shift 2 ;;
    --hosts) hosts=$2; shift 2 ;;
    --robots) robots=$2; shift 2 ;;
    --resume) resume=1; shift ;;
    --measure) measure=$2; shift 2 ;;
    --timeout) timeout=$2; shift 2 ;;
    --time-scale) time_scale=$2; shift 2 ;;
    --logs) logs=$2; shift 2 ;;
    *) say "unknown argument '$1'"; usage ;;
  esac
done
case $ros in 1|2) ;; *) say "--ros $ros is invalid: must be 1 or 2"; exit 2 ;; esac
[[ $hosts =~ ^[0-9]+$ ]] && [ "$hosts" -ge 1 ] && [ "$hosts" -le 200 ] || { say "--hosts $hosts is invalid: must be 1 .. 200"; exit 2; }
[[ $robots =~ ^[0-9]+$ ]] && [ "$robots" -ge 1 ] || { say "--robots $robots is invalid: must be a whole number >= 1"; exit 2; }
[[ $measure =~ ^[0-9]+$ ]] || { say "--measure $measure is invalid: must be whole seconds"; exit 2; }
[[ $timeout =~ ^[0-9]+$ ]] || { say "--timeout $timeout is invalid: must be whole seconds"; exit 2; }
[[ $time_scale =~ ^[0-9]+(\.[0-9]+)?$ ]] || { say "--time-scale $time_scale is invalid: must be a positive number"; exit 2; }
[ -z "$logs" ] || mkdir -p "$logs" || { say "--logs $logs: cannot make that directory"; exit 2; }
[[ $time_scale == *.* ]] || time_scale=$time_scale.0   # a ROS 2 double parameter refuses an integer
[ "$resume" = 0 ] || [ "$hosts" -ge 2 ] || { say "--resume needs --hosts 2 or more (host 1 is killed)"; exit 2; }

# Where namespaces cannot be made, say why (the test skips with that reason).
[ "$(id -u)" -eq 0 ] || { say "cannot make network namespaces: not root"; exit 77; }
command -v ip >/dev/null && ip netns list >/dev/null 2>&1 || { say "cannot make network namespaces: no 'ip netns'"; exit 77; }

total=$((hosts * robots))
run=bsf$$                      # unique per run: namespaces bsf<pid>br (bridge), bsf<pid>o (observer), bsf<pid>h<k>
dir=$(mktemp -d "${TMPDIR:-/tmp}/netns_fleet_$$.XXXXXX")
namespaces=() pids=()

cleanup() {
  local pid
  exec 3>&- 2>/dev/null || true
  for pid in "${pids[@]}"; do kill -INT "$pid" 2>/dev/null || true; done
  for pid in "${pids[@]}"; do
    for _ in $(seq 50); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
    kill -KILL "$pid" 2>/dev/null || true
  done
  for ns in "${namespaces[@]}"; do ip netns del "$ns" 2>/dev/null || true; done
  [ -z "$logs" ] || cp "$dir"/*.log "$dir"/observer.* "$logs"/ 2>/dev/null || true
  rm -rf "$dir"
}
trap cleanup EXIT
trap 'exit 130' INT
trap 'exit 143' TERM

make_namespace() {   # NAME [ADDRESS]: a namespace (lo up), joined to the bridge when it has an address
  local ns=$1 address=$2 port=p${#namespaces[@]}
  ip netns add "$ns"
  namespaces+=("$ns")
  ip -n "$ns" link set lo up
  [ -n "$address" ] || return 0
  ip -n "$run"br link add "$port" type veth peer name eth0 netns "$ns"
  ip -n "$run"br link set "$port" master br0 up
  ip -n "$ns" addr add "$address/24" dev eth0
  ip -n "$ns" link set eth0 up
}

start_in() {   # NAMESPACE LOG COMMAND...: start COMMAND there (guarded), remember its pid in $started
  local ns=$1 log=$2; shift 2
  refuse_unless_fenced "$ns" || exit 2
  ip netns exec "$ns" "$@" >>"$log" 2>&1 &
  started=$!
  disown "$started"   # ended by pid here; no job notice when one is killed on purpose
  pids+=("$started")
}

host_ip() { echo "$SUBNET.$((10 + $1))"; }

# The environment of a ROS process in namespace of address $1 (ROS 2: a discovery client over UDPv4 only).
ros_env() {
  if [ "$ros" = 2 ]; then
    echo "$root/tools/ros2.sh" env -u FASTDDS_DEFAULT_PROFILES_FILE FASTDDS_BUILTIN_TRANSPORTS=UDPv4 \
         ROS_DISCOVERY_SERVER="$OBSERVER_IP:$DISCOVERY_PORT" ROS_LOG_DIR="$dir/log"
  else
    # (ROS_HOSTNAME, when set, would win over ROS_IP)
    echo env -u ROS_HOSTNAME ROS_MASTER_URI="http://$OBSERVER_IP:$MASTER_PORT" ROS_IP="$1" ROS_HOME="$dir" ROS_LOG_DIR="$dir/log"
  fi
}

# K: fleet host K (robots K x robots ...), pid in host_pids[K]. On ROS 2 its node gets its own name by a
# remap of that node only: a global __ns remap would move every robot node of the process as well.
start_host() {
  local k=$1 first=$(($1 * robots))
  if [ "$ros" = 2 ]; then
    # shellcheck disable=SC2046
    start_in "$run"h"$k" "$dir/host$k.log" $(ros_env) battery_fleet --ros-args -p robots:=$robots -p first:=$first \
      -p update_rate:=2.0 -p time_scale:="$time_scale" -p state_file:="$dir/host$k.json" \
      -r battery_fleet:__node:=$([ "$k" = 0 ] && echo battery_fleet || echo "battery_fleet_$k")
  else
    # shellcheck disable=SC2046
    start_in "$run"h"$k" "$dir/host$k.log" $(ros_env "$(host_ip "$k")") /usr/bin/python3 "$root/scripts/battery_fleet.py" \
      __name:=$([ "$k" = 0 ] && echo battery_fleet || echo "battery_fleet_$k") \
      _robots:=$robots _first:=$first _update_rate:=2.0 _time_scale:="$time_scale"
  fi
  host_pids[$k]=$started
}

ask() {   # COMMAND BOUND_S: send the observer COMMAND, print its answer line (within BOUND_S)
  local before
  before=$(wc -l <"$dir/observer.out")
  echo "$1" >&3
  for _ in $(seq $(($2 * 10))); do
    if [ "$(wc -l <"$dir/observer.out")" -gt "$before" ]; then sed -n "$((before + 1))p" "$dir/observer.out"; return; fi
    kill -0 "$observer_pid" 2>/dev/null || break
    sleep 0.1
  done
  say "the observer gave no answer to '$1' (log: its last lines below)"; tail -5 "$dir/observer.err" >&2; exit 1
}

cpu_ticks() { awk '{print $14 + $15}' "/proc/$1/stat" 2>/dev/null || echo 0; }
rss_mb() { awk '/^VmRSS:/ {printf "%.0f", $2 / 1024}' "/proc/$1/status" 2>/dev/null || echo 0; }
tree_pids() { echo "$1"; local child; for child in $(pgrep -P "$1"); do tree_pids "$child"; done; }   # roscore: its children

if [ "$ros" = 1 ]; then
  [ -f "$root/build/devel/setup.bash" ] || "$root/tools/build.sh" >/dev/null
  # shellcheck disable=SC1091
  source "$root/build/devel/setup.bash"
else
  "$root/tools/ros2.sh" true
fi

# The machines: a bridge namespace, the observer, the hosts (the root namespace gets nothing).
ip netns add "$run"br; namespaces+=("$run"br)
ip -n "$run"br link set lo up
ip -n "$run"br link add br0 type bridge
ip -n "$run"br link set br0 up
make_namespace "$run"o "$OBSERVER_IP"
for k in $(seq 0 $((hosts - 1))); do make_namespace "$run"h"$k" "$(host_ip "$k")"; done

# The server (ROS 2) or master (ROS 1) in the observer namespace, then the observer.
if [ "$ros" = 2 ]; then
  venv="$root/build/.ros2/venv"
  start_in "$run"o "$dir/server.log" env LD_LIBRARY_PATH="$venv/lib:$venv/lib/python3.11/site-packages/ros_fastdds.libs" \
    "$venv/bin/fast-discovery-server" 42 -l "$OBSERVER_IP" -p "$DISCOVERY_PORT"
  server_pids=$started
  for _ in $(seq 300); do grep -q 'Server started' "$dir/server.log" && break; sleep 0.1; done
  observer_env="$(ros_env) ROS_SUPER_CLIENT=TRUE"
else
  start_in "$run"o "$dir/server.log" $(ros_env "$OBSERVER_IP") roscore -p "$MASTER_PORT"
  server_pid=$started
  for _ in $(seq 300); do
    ip netns exec "$run"o env ROS_MASTER_URI="http://$OBSERVER_IP:$MASTER_PORT" rosnode list 2>/dev/null | grep -q rosout && break
    sleep 0.1
  done
  server_pids=$(tree_pids "$server_pid")
  observer_env="$(ros_env "$OBSERVER_IP")"
fi
mkfifo "$dir/observer.in"
: >"$dir/observer.out"
# shellcheck disable=SC2086
refuse_unless_fenced "$run"o || exit 2
ip netns exec "$run"o $observer_env $([ "$ros" = 2 ] && echo python3 || echo /usr/bin/python3) \
  "$root/tools/netns_fleet_observer.py" "$total" <"$dir/observer.in" >"$dir/observer.out" 2>"$dir/observer.err" &
observer_pid=$!
pids+=("$observer_pid")
exec 3>"$dir/observer.in"

start_s=$(date +%s.%N)
declare -a host_pids
for k in $(seq 0 $((hosts - 1))); do start_host "$k"; done

status=0
seen=$(ask "seen $timeout $start_s" $((timeout + 30)))
echo "$seen"
[[ $seen =~ ^seen\ ([0-9]+)\ of\ ([0-9]+) ]] && [ "${BASH_REMATCH[1]}" = "${BASH_REMATCH[2]}" ] || status=1

if [ "$measure" -gt 0 ] && [ $status = 0 ]; then
  measured_pids="$server_pids ${host_pids[*]}"
  declare -A before
  for pid in $measured_pids; do before[$pid]=$(cpu_ticks "$pid"); done
  echo "$(ask "rates $measure" $((measure + 30)))"
  tick=$(getconf CLK_TCK)
  percent() { local sum=0 pid; for pid in "$@"; do sum=$((sum + $(cpu_ticks "$pid") - ${before[$pid]})); done
              awk -v t="$sum" -v hz="$tick" -v s="$measure" 'BEGIN {printf "%.1f", 100 * t / hz / s}'; }
  memory() { local sum=0 pid; for pid in "$@"; do sum=$((sum + $(rss_mb "$pid"))); done; echo $sum; }
  # shellcheck disable=SC2086
  echo "$([ "$ros" = 2 ] && echo "discovery server" || echo "master (roscore, rosout)"): $(percent $server_pids) % of a core, $(memory $server_pids) MB RSS; hosts: $(percent "${host_pids[@]}") % of a core, $(memory "${host_pids[@]}") MB RSS ($hosts processes, over $measure s)"
fi

if [ "$resume" = 1 ] && [ $status = 0 ]; then
  killed_s=$(date +%s.%N)
  kill -KILL "${host_pids[1]}"
  for _ in $(seq 100); do kill -0 "${host_pids[1]}" 2>/dev/null || break; sleep 0.05; done
  echo "killed $killed_s $robots $robots" >&3
  logged=$(wc -l <"$dir/host1.log")
  restarted_s=$(date +%s.%N)
  start_host 1
  # the observer reads the host's log past its first $logged lines (the restarted host's) as it grows
  answer=$(ask "resumed $restarted_s $timeout $dir/host1.log $logged" $((timeout + 30)))
  # the host's own word that each robot resumed from its saved state (not a fresh start at its first level)
  for _ in $(seq 100); do   # (the host may log its lines after its robots publish again)
    resumed_logged=$(tail -n +$((logged + 1)) "$dir/host1.log" | grep -c 'resumed from' || true)
    [ "$resumed_logged" -lt "$robots" ] || break
    sleep 0.1
  done
  echo "host 1 killed with SIGKILL and started again: $answer; $resumed_logged of $robots logged 'resumed from'"
  [[ $answer =~ within\ 1\ %:\ yes ]] && [ "$resumed_logged" = "$robots" ] || status=1
fi
echo quit >&3
if [ $status != 0 ]; then   # what went wrong: the last lines of every log
  for log in "$dir"/*.log "$dir/observer.err"; do say "${log##*/}:"; tail -3 "$log" >&2; done
fi
exit $status
