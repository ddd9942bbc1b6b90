#!/bin/bash
# Mutation score of the masterless unit tests on the ROS-free core, with mutmut
# (a developer tool from PyPI, in a venv of its own made with
# --system-site-packages; never a runtime dependency).
#
#   tools/mutation.sh                          # the default modules (below) against test/core/
#   tools/mutation.sh pack gauge               # only these modules of src/battery_simulator/core/
#   tools/mutation.sh pack gauge -- test/core/test_pack_cycles.py test/core/test_pack.py
#                                              # ... and run only these tests (a loaded machine)
#
# A module is a name under src/battery_simulator/core/ (pack) or a path from the
# repository's root (src/battery_simulator/ros1/log.py); one that does not exist
# stops the run with its name, before anything is mutated. It works in a copy
# (build/mutation/), with the generated message modules beside the sources when a
# build has them (tools/build.sh), so the mutants and not the checkout are what
# the tests import.
set -eo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
export PATH="/usr/bin:$PATH"
modules=()
tests=()
while [ $# -gt 0 ]; do
  if [ "$1" = "--" ]; then shift; tests=("$@"); break; fi
  modules+=("$1"); shift
done
[ ${#modules[@]} -gt 0 ] || modules=(battery_model pack gauge parameter_rules replay)
[ ${#tests[@]} -gt 0 ] || tests=(test/core/)
paths=()
for module in "${modules[@]}"; do
  case $module in
    */*) path=$module ;;
    *) path=src/battery_simulator/core/$module.py ;;
  esac
  [ -f "$root/$path" ] || { echo "mutation.sh: no module $module ($path does not exist)" >&2; exit 2; }
  paths+=("$path")
done
for test in "${tests[@]}"; do
  [ -e "$root/$test" ] || { echo "mutation.sh: no test $test" >&2; exit 2; }
done
venv="$root/build/mutation-venv"
if [ ! -x "$venv/bin/mutmut" ]; then
  /usr/bin/python3 -m venv --system-site-packages "$venv"
  "$venv/bin/pip" install -q 'mutmut==3.8.1'
fi
work="$root/build/mutation"
rm -rf "$work"
mkdir -p "$work"
# what the tests read beside the sources (interface files, launch files, the package manifest)
copied=()
for entry in src test config docs action msg srv cfg launch scripts package.xml CMakeLists.txt; do
  if [ -e "$root/$entry" ]; then cp -r "$root/$entry" "$work/"; copied+=("$entry"); fi
done
generated="$root/build/devel/lib/python3/dist-packages/battery_simulator"
for package in msg srv cfg; do
  if [ -d "$generated/$package" ]; then cp -r "$generated/$package" "$work/src/battery_simulator/"; fi
done
cat > "$work/setup.cfg" <<CFG
[mutmut]
source_paths =
$(printf '  %s\n' "${paths[@]}")
pytest_add_cli_args_test_selection =
$(printf '  %s\n' "${tests[@]}")
also_copy =
$(printf '  %s\n' "${copied[@]}")
pytest_add_cli_args =
  -p
  no:cacheprovider
  --ignore=test/package/test_packaging.py
  --ignore=test/tools/test_summarize_test_results.py
  --ignore=test/package/test_paths_exist.py
CFG
cd "$work"
unset ROS_PACKAGE_PATH CMAKE_PREFIX_PATH
export PYTHONPATH="$work/src"
"$venv/bin/mutmut" run --max-children 2 >mutmut.log 2>&1 || { tail -30 mutmut.log; exit 1; }
"$venv/bin/mutmut" results --all true > results.txt 2>&1 || true
/usr/bin/python3 - "$work/results.txt" <<'PY'
import collections, sys
counts = collections.defaultdict(collections.Counter)
for line in open(sys.argv[1]):
    line = line.strip()
    if ': ' not in line or '__mutmut_' not in line:
        continue
    name, status = line.rsplit(': ', 1)
    module = name.split('.x_')[0].split('.')[-1] if '.x_' in name else name.split('.')[-2]
    counts[module][status] += 1
if not counts:
    sys.exit('mutation.sh: mutmut reported no mutants (see build/mutation/mutmut.log)')
print('%-16s %7s %7s %9s %7s %7s' % ('module', 'mutants', 'killed', 'survived', 'other', 'score'))
for module in sorted(counts):
    c = counts[module]
    total = sum(c.values())
    killed = c['killed'] + c['timeout']
    print('%-16s %7d %7d %9d %7d %6.1f%%' % (module, total, killed, c['survived'], total - killed - c['survived'],
                                               100.0 * killed / max(1, total)))
PY
echo "survivors: cd $work && $venv/bin/mutmut results; $venv/bin/mutmut show NAME"
