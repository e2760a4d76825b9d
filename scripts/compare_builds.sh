#!/usr/bin/env bash
# Renders the same small images with two builds of `vsl` and compares the
# EXRs' pixels byte for byte (scripts/exr_pixels_equal.py: the headers
# carry each build's describe() text and version): a refactoring must leave every render bit-identical
# (docs/ARCHITECTURE.md, "Refactoring").
#
#   bash scripts/compare_builds.sh OLD_VSL NEW_VSL [OUT_DIR]
#
# Every bundled scene, with the many-light methods (--method all: VSL, clamped
# VPL and the VPL variants from one light set) under brute force and MRCS, at
# the default settings, the paper preset and with each heuristic and variant
# switched on. Exit 0 when every pair is identical, 1 otherwise.
set -euo pipefail
old=$1 new=$2 out=${3:-$(mktemp -d)}
here=$(cd "$(dirname "$0")/.." && pwd)
base=(--method all --width 40 --lights 600 --batches 2 --direct-samples 2)
variants=(
  ""
  "--preset paper"
  "--mrcs 60,120"
  "--mrcs 60,120,0.3 --mrcs-spread"
  "--radius 0.05 --vsl-samples 3 --clamp 0.5"
  "--radius-scale 1.7 --knn 4 --clamp off --diffuse-vpl --clipped-disk"
  "--vsl-count shares --lobe-radius 0.5 --lobe-floor 0.5 --continue-alpha 0.1"
  "--split-alpha 0.05 --pair-roulette 1"
  "--lobe-gather 200 --lobe-gather-rays 4 --lobe-gather-alpha 0.15"
)
mkdir -p "$out/old" "$out/new"
same=0 differ=0
for scene in "$here"/assets/scenes/*.gltf; do
  name=$(basename "$scene" .gltf)
  for i in "${!variants[@]}"; do
    # shellcheck disable=SC2206
    extra=(${variants[$i]})
    for which in old new; do
      bin=$old
      [ "$which" = new ] && bin=$new
      "$bin" render "$scene" "${base[@]}" "${extra[@]}" -o "$out/$which/$name-$i.exr" >/dev/null 2>&1 ||
        { echo "FAILED: $which $name ${variants[$i]}"; exit 1; }
    done
    if python3 "$here/scripts/exr_pixels_equal.py" "$out/old/$name-$i.exr" "$out/new/$name-$i.exr"; then
      same=$((same + 1))
    else
      differ=$((differ + 1))
      echo "DIFFERS: $name ${variants[$i]}"
    fi
  done
done
echo "$same identical, $differ different (EXRs in $out)"
[ "$differ" -eq 0 ]
