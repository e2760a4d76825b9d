#!/usr/bin/env bash
# Reproduces the scale and speed-accuracy figures of docs/RESULTS.md
# (issue 5's targets) on the bundled scenes. Long: about an hour on 2 cores.
#   bash scripts/measure-scale.sh [OUT_DIR] [SIZE]
# SIZE (default 512) is the square image size; TIME (default 60) the
# equal-time budget in seconds. Every step writes its EXR and
# JSON into OUT_DIR (default out/scale); results.txt collects the numbers.
# Steps whose output already exists are skipped, so an interrupted run resumes.
set -euo pipefail
cd "$(dirname "$0")/.."
OUT=${1:-out/scale}
SIZE=${2:-512}
TIME=${TIME:-60}  # equal-time budget, seconds
VSL=${VSL:-build/bin/vsl}  # override to measure a fixed copy while rebuilding
[ -x "$VSL" ] || bash scripts/build.sh
mkdir -p "$OUT"
RES="$OUT/results.txt"
log() { echo "$*" | tee -a "$RES"; }
step() {  # step NAME OUTPUT COMMAND...: runs COMMAND unless OUTPUT exists
  local name=$1 out=$2
  shift 2
  if [ -e "$out" ]; then
    echo "skip $name ($out exists)"
  else
    echo "== $name: $*"
    "$@"
  fi
}
relmse() {  # relmse TEST REF: relMSE of the indirect layers
  "$VSL" compare "$1" "$2" --layer indirect --json | python3 -c 'import json,sys; print(json.load(sys.stdin)["average"]["relMSE"])'
}
seconds() {  # seconds JSON: render time of a many-light run
  python3 -c 'import json,sys; j=json.load(open(sys.argv[1])); print(round(j["seconds"]["total"], 2))' "$1"
}
S="--width $SIZE --height $SIZE"

for scene in kitchen tableau; do
  G=assets/scenes/$scene.gltf
  # Two independent references: A is the reference, |A - B| measures its own noise.
  step "$scene reference A" "$OUT/$scene-refA.exr" "$VSL" render "$G" $S --spp 1024 --seed 7 -o "$OUT/$scene-refA.exr"
  step "$scene reference B" "$OUT/$scene-refB.exr" "$VSL" render "$G" $S --spp 1024 --seed 8 -o "$OUT/$scene-refB.exr"
done

# Target: 100,000 VSLs at SIZE^2 with MRCS in <= 60 s, relMSE <= 1.25x brute force.
G=assets/scenes/kitchen.gltf
step "MRCS 100k" "$OUT/mrcs.json" "$VSL" render "$G" $S --method vsl --lights 100000 --mrcs 300,900 \
  --direct-samples 1 -o "$OUT/mrcs.exr" --json "$OUT/mrcs.json"
# Target: equal time (60 s), VSL indirect relMSE <= 1/10 of the path tracer's.
for scene in kitchen tableau; do
  step "$scene sweep" "$OUT/sweep-$scene/sweep.csv" "$VSL" sweep "assets/scenes/$scene.gltf" \
    --methods pt,vsl-mrcs,vpl-mrcs --lights 30000,100000 --time "$TIME" \
    --reference "$OUT/$scene-refA.exr" --reference-b "$OUT/$scene-refB.exr" -o "$OUT/sweep-$scene"
done

# The brute-force gather for the MRCS comparison (~26 G pairs at 512^2: the long step).
step "brute force 100k" "$OUT/brute.json" "$VSL" render "$G" $S --method vsl --lights 100000 --batches 1 \
  --direct-samples 1 -o "$OUT/brute.exr" --json "$OUT/brute.json"


log "== $(date -u +%F) size ${SIZE}x${SIZE}, equal-time budget $TIME s"
for scene in kitchen tableau; do
  log "$scene: reference noise relMSE(A, B) = $(relmse "$OUT/$scene-refA.exr" "$OUT/$scene-refB.exr")"
done
log "MRCS 100k: $(seconds "$OUT/mrcs.json") s, relMSE vs reference $(relmse "$OUT/mrcs.exr" "$OUT/kitchen-refA.exr")"
log "brute force 100k: $(seconds "$OUT/brute.json") s, relMSE vs reference $(relmse "$OUT/brute.exr" "$OUT/kitchen-refA.exr")"
log "MRCS vs brute force directly: relMSE $(relmse "$OUT/mrcs.exr" "$OUT/brute.exr")"
for scene in kitchen tableau; do
  log "$scene sweep (final points, relMSE against reference A):"
  awk -F, 'NR > 1 && $11 == 1' "$OUT/sweep-$scene/sweep.csv" | tee -a "$RES"
done
echo "results in $RES"
