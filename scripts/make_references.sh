#!/usr/bin/env bash
# Renders the references shipped in assets/references/ (docs/REFERENCE.md,
# "References"): every bundled scene at the studio's default width (256) and
# at 64 for tests, each to the relMSE noise given (its own noise, from two
# independent halves), named by its cache key so that the studio and
# `vsl sweep` find it. Each run prints its command and figures (samples,
# own noise, seconds) for the table in assets/references/README.md.
#   bash scripts/make_references.sh [SCENE...]     (default: every bundled scene)
# Environment: WIDTHS (default "256 64"), NOISE (default 0.002), SPP_MAX
# (default 65536), TIME (seconds per reference, default 3600), METHOD (pt or
# bdpt, default pt: `vsl reference --method`).
set -euo pipefail
cd "$(dirname "$0")/.."
vsl=build/bin/vsl
[ -x "$vsl" ] || { echo "build first: bash scripts/build.sh" >&2; exit 1; }
out=assets/references
mkdir -p "$out"
scenes=("$@")
[ ${#scenes[@]} -gt 0 ] || scenes=(assets/scenes/*.gltf)
for scene in "${scenes[@]}"; do
  for width in ${WIDTHS:-256 64}; do
    cmd="VSL_REFERENCE_CACHE=$out vsl reference $scene --width $width --target-relmse ${NOISE:-0.002} --spp ${SPP_MAX:-65536} --time ${TIME:-3600} --method ${METHOD:-pt} --half"
    echo "== $cmd"
    VSL_REFERENCE_CACHE=$out "$vsl" reference "$scene" --width "$width" --target-relmse "${NOISE:-0.002}" \
      --spp "${SPP_MAX:-65536}" --time "${TIME:-3600}" --method "${METHOD:-pt}" --half
  done
done
