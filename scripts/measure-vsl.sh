#!/usr/bin/env bash
# Reproduces issue 14's VSL measurements (docs/notebook/): VSL against
# clamped VPL over independent light sets, the radius scale and k, and where
# eye paths continue through narrow metals.
#   bash scripts/measure-vsl.sh [OUT_DIR] [WIDTH] [STUDY...]
# STUDY: radius (scales 1 and 2 at 2,000 and 10,000 lights), knn (k = 5 and
# 20 at scale 2), lobe (the lobe-aware minimum radius), continue
# (--continue-alpha on a near-mirror box), split (--split-alpha 0 and 0.05:
# narrow specular lobes continue the eye path), compare (VSL vs VPL at 10,000
# lights with the default settings), equal (each method's best configuration
# at an equal time budget). Environment: TIME (budget, default 10), MRCS, SETS (default 5), SPP
# (reference samples per pixel for each of the two references, default 4096),
# SCENES (default: cornell-glossy tableau kitchen hall), VSL (the binary),
# EXTRA (options added to every sweep; EXTRA='--lobe-floor 0' reproduces the
# tables made before the lobe floor became a default on 2026-12-03).
# Every sweep writes OUT_DIR/<scene>-<study>/summary.csv; finished steps are
# skipped, so an interrupted run resumes.
set -euo pipefail
cd "$(git -C "$(dirname "$0")" rev-parse --show-toplevel)"
OUT=${1:-out/vsl}
WIDTH=${2:-64}
shift 2 || true
STUDIES=${*:-radius continue compare}
SETS=${SETS:-5}
TIME=${TIME:-10}         # equal-time budget, seconds
MRCS=${MRCS:-100,300}    # rows,clusters for the -mrcs methods
SPP=${SPP:-4096}
SCENES=${SCENES:-cornell-glossy tableau kitchen hall}
VSL=${VSL:-build/bin/vsl}
[ -x "$VSL" ] || bash scripts/build.sh
mkdir -p "$OUT"

scene_path() { [ -f "$1" ] && echo "$1" || echo "assets/scenes/$1.gltf"; }
# Two independent path-traced references per scene: A is the reference, and
# relMSE(B, A)/2 its own noise, which the sweeps subtract.
references() {  # references NAME PATH
  for s in A:7 B:8; do
    local tag=${s%%:*} seed=${s##*:} f="$OUT/$1-ref${s%%:*}.exr"
    [ -e "$f" ] || "$VSL" render "$2" --method pt --spp "$SPP" --width "$WIDTH" --seed "$seed" -o "$f"
  done
}
sweep() {  # sweep NAME PATH SUBDIR ARGS... (equal quality: no time cap, one batch)
  sweep_args "$@" --time 100000 --batches 1
}
sweep_args() {  # sweep_args NAME PATH SUBDIR ARGS...
  local name=$1 path=$2 dir="$OUT/$1-$3"
  shift 3
  if [ -e "$dir/summary.csv" ]; then echo "skip $dir"; return; fi
  "$VSL" sweep "$path" --reference "$OUT/$name-refA.exr" --reference-b "$OUT/$name-refB.exr" --sets "$SETS" \
    -o "$dir" "$@" ${EXTRA:-} | tee "$dir.txt"
}

for study in $STUDIES; do
  case $study in
    radius)
      for s in $SCENES; do
        p=$(scene_path "$s"); n=$(basename "$p" .gltf)
        references "$n" "$p"
        sweep "$n" "$p" radius-k10 --methods vpl,vsl --lights 2000,10000 --radius-scale 1,2
      done ;;
    knn)
      for s in $SCENES; do
        p=$(scene_path "$s"); n=$(basename "$p" .gltf)
        references "$n" "$p"
        sweep "$n" "$p" radius-k5 --methods vsl --lights 10000 --radius-scale 2 --knn 5
        sweep "$n" "$p" radius-k20 --methods vsl --lights 10000 --radius-scale 2 --knn 20
      done ;;
    lobe)
      for s in $SCENES; do
        p=$(scene_path "$s"); n=$(basename "$p" .gltf)
        references "$n" "$p"
        sweep "$n" "$p" lobe-1 --methods vsl --lights 10000 --radius-scale 1,2 --lobe-radius 1
      done ;;
    continue)
      # The default scene with its metal box made a near-mirror (roughness 0.1, alpha 0.01).
      p="$OUT/cornell-mirror.gltf"
      python3 - "$p" <<'PY'
import json, sys
g = json.load(open("assets/scenes/cornell-glossy.gltf"))
for m in g["materials"]:
    if m["name"] == "metal":
        m["pbrMetallicRoughness"]["roughnessFactor"] = 0.1
json.dump(g, open(sys.argv[1], "w"))
PY
      references cornell-mirror "$p"
      for a in 0.01 0.02 0.05; do
        sweep cornell-mirror "$p" "continue-$a" --methods vpl,vsl --lights 10000 --continue-alpha "$a"
      done
      # And through every metal of the glossy scenes (alpha 0.04-0.12 there).
      for s in $SCENES; do
        p=$(scene_path "$s"); n=$(basename "$p" .gltf)
        references "$n" "$p"
        sweep "$n" "$p" continue-0.15 --methods vpl,vsl --lights 10000 --continue-alpha 0.15
      done ;;
    split)
      # Lobe splitting: narrow specular lobes continue the eye path (--split-alpha).
      for s in $SCENES; do
        p=$(scene_path "$s"); n=$(basename "$p" .gltf)
        references "$n" "$p"
        for a in 0 0.05; do
          sweep "$n" "$p" "split-$a" --methods vpl,vsl --lights 10000 --split-alpha "$a"
        done
      done ;;
    compare)
      for s in $SCENES; do
        p=$(scene_path "$s"); n=$(basename "$p" .gltf)
        references "$n" "$p"
        sweep "$n" "$p" compare --methods vpl,vsl --lights 10000
      done ;;
    equal)
      # Equal time: each method's own clock; every configuration of a method
      # gets the budget (brute force in batches, or independent MRCS light
      # sets averaged), and each method is judged by its best configuration.
      for s in $SCENES; do
        p=$(scene_path "$s"); n=$(basename "$p" .gltf)
        references "$n" "$p"
        sweep_args "$n" "$p" "equal-$TIME" --methods pt,vpl,vsl,vpl-mrcs,vsl-mrcs --lights 2000,10000 \
          --mrcs "$MRCS" --time "$TIME" --batches 8
      done ;;
    *) echo "unknown study '$study'" >&2; exit 2 ;;
  esac
done
echo "done: $OUT"
