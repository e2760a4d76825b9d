#!/usr/bin/env bash
# The studio's first picture at 1,000,000 VSLs (docs/RESULTS.md, "Stochastic
# lightcuts"): opens vsl-studio in a window under Xvfb RUNS times (default 5)
# on kitchen with stochastic lightcuts at 256 px, reads each launch's
# "first picture N ms after launch" from its log, closes it, and prints the
# times and their median. Needs build/bin/vsl-studio and xvfb-run.
#   bash scripts/measure-first-picture.sh [RUNS] [STUDIO ARGS...]
set -euo pipefail
cd "$(dirname "$0")/.."
runs=${1:-5}
shift || true
args=(assets/scenes/kitchen.gltf --lights 1000000 --estimator slc --width 256 --fresh --verbose "$@")
log=$(mktemp)
trap 'rm -f "$log"' EXIT
times=()
for ((i = 1; i <= runs; ++i)); do
  xvfb-run -a -s "-screen 0 1280x800x24" bash -c '
    build/bin/vsl-studio "${@:2}" >"$1" 2>&1 &
    pid=$!
    for _ in $(seq 300); do
      sleep 0.1
      grep -q "first picture .* after launch" "$1" && break
    done
    kill "$pid" 2>/dev/null || true
    wait "$pid" 2>/dev/null || true' _ "$log" "${args[@]}"
  ms=$(sed -n 's/.*first picture \([0-9]*\) ms after launch.*/\1/p' "$log" | head -1)
  if [ -z "$ms" ]; then
    echo "run $i: no first picture within 30 s; the studio's log:" >&2
    cat "$log" >&2
    exit 1
  fi
  echo "run $i: first picture ${ms} ms after launch"
  times+=("$ms")
done
printf '%s\n' "${times[@]}" | sort -n | awk '{a[NR]=$1} END {m = NR % 2 ? a[(NR+1)/2] : (a[NR/2]+a[NR/2+1])/2; printf "median %d ms over %d runs (%d-%d)\n", m, NR, a[1], a[NR]}'
