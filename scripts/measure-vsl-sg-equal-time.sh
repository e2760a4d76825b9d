#!/usr/bin/env bash
# The closed-form VSL at equal time (docs/RESULTS.md, "Closed-form VSL by
# spherical Gaussians", "At equal time"): 256 px, 15 s on each method's own
# clock, five light sets; VSL with the quadrature and in closed form from the
# same flags, clamped VPL in its best configuration and the path tracer, on kitchen, hall and
# tableau. Renders hall's and tableau's 256-px references first (7 minutes
# each; kitchen's is shipped). About 35 minutes on 2 cores.
#   bash scripts/measure-vsl-sg-equal-time.sh OUT
set -euo pipefail
cd "$(dirname "$0")/.."
O=${1:?usage: measure-vsl-sg-equal-time.sh OUT}
V=build/bin/vsl
mkdir -p "$O"
for s in hall tableau; do
  [ -f "$O/$s-256.exr" ] ||
    $V reference assets/scenes/$s.gltf --width 256 --time 420 --target-relmse 0.04 --seed 4242 -o "$O/$s-256.exr"
done
run() { # scene reference name lights methods [flags...]
  local s=$1 r=$2 n=$3 L=$4 m=$5
  shift 5
  echo "== $s $n"
  $V sweep assets/scenes/$s.gltf --reference "$r" --sets 5 --time 15 --methods "$m" --lights "$L" "$@" \
    -o "$O/$s-$n" >"$O/$s-$n.log" 2>&1
  grep -A3 '^configuration' "$O/$s-$n.log"
}
K=assets/references/kitchen-593ae4e502c4f697-256x192-d64.exr
run kitchen $K vsl 5000 vsl-quadrature,vsl-sg --vsl-samples 2 --lobe-gather 100000 --lobe-gather-rays 16
run kitchen $K vpl 10000 vpl
run kitchen $K defaults 10000 vsl-quadrature,vsl-sg
run kitchen $K pt 1000 pt
H=$O/hall-256.exr
run hall "$H" vsl 4000 vsl-quadrature,vsl-sg --vsl-samples 1 --lobe-gather 100000 --lobe-gather-rays 4 --batches 64 \
  --pair-roulette 1 --lobe-gather-alpha 0.15
run hall "$H" vpl 15000 vpl --batches 64 --pair-roulette 3
run hall "$H" defaults 10000 vsl-quadrature,vsl-sg
run hall "$H" pt 1000 pt
T=$O/tableau-256.exr
run tableau "$T" vsl 1500 vsl-quadrature,vsl-sg --vsl-count shares --lobe-gather 100000 --lobe-gather-rays 24 --batches 64
run tableau "$T" vpl 15000 vpl --batches 64 --pair-roulette 1
run tableau "$T" defaults 10000 vsl-quadrature,vsl-sg
run tableau "$T" pt 1000 pt
