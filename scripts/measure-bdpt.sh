#!/usr/bin/env bash
# Equal-time convergence of the two reference renderers, the path tracer and
# BDPT (docs/RESULTS.md, "Bidirectional path tracing as the reference"). Per
# scene and method: independent `vsl reference` runs of RUN_SECONDS each
# (seeds SEEDS, default "1 2", WIDTH pixels wide), then
#   - pixel samples per second (spp x pixels / seconds, the mean of the runs);
#   - relMSE(first run, second run) / 4 of the indirect layer: the expected
#     error of the two runs' mean (core/reference.h);
#   - relMSE of each run against the shipped reference of that size, less the
#     reference's own noise, when one is shipped: median [min, max] over the
#     runs.
# One line per scene and method, tab-separated. Runs one render at a time.
#   bash scripts/measure-bdpt.sh [SCENE...]   (default: every bundled scene)
# Environment: WIDTH (64), RUN_SECONDS (10), SEEDS ("1 2"), OUT (/tmp/vsl-bdpt).
set -euo pipefail
cd "$(dirname "$0")/.."
vsl=build/bin/vsl
[ -x "$vsl" ] || { echo "build first: bash scripts/build.sh" >&2; exit 1; }
width=${WIDTH:-64}
seconds=${RUN_SECONDS:-10}
out=${OUT:-/tmp/vsl-bdpt}
mkdir -p "$out"
scenes=("$@")
[ ${#scenes[@]} -gt 0 ] || scenes=(assets/scenes/*.gltf)

# relmse TEST REF: the indirect layer's average relMSE (vsl compare).
relmse() {
  "$vsl" compare --layer indirect --json --no-flip "$1" "$2" 2>/dev/null |
    python3 -c 'import json,sys; print(json.load(sys.stdin)["average"]["relMSE"])'
}
# attr FILE NAME: an EXR attribute (vsl.reference.*) as text.
attr() { exrheader "$1" | sed -n "s/^$2 (type string): \"\(.*\)\"/\1/p"; }

printf "scene\tmethod\tspp\tsamples/s\trelMSE(A,B)/4\trelMSE vs shipped - its noise\tshipped noise\n"
for scene in "${scenes[@]}"; do
  name=$(basename "$scene" .gltf)
  for method in pt bdpt; do
    seeds=(${SEEDS:-1 2})
    runs=()
    for seed in "${seeds[@]}"; do
      nice "$vsl" reference "$scene" --method "$method" --width "$width" --time "$seconds" --seed "$seed" \
        --no-cache -o "$out/$name-$method-$seed.exr" 2>"$out/$name-$method-$seed.log"
      runs+=("$out/$name-$method-$seed.exr")
    done
    a=${runs[0]} b=${runs[1]}
    spp=$(attr "$a" vsl.reference.spp)
    rate=$(python3 - "${runs[@]}" <<EOF
import re, subprocess, sys
def num(f, k):
    out = subprocess.run(["exrheader", f], capture_output=True, text=True).stdout
    for line in out.splitlines():
        if line.startswith(k + " "):
            return float(line.split('"')[1])
    return 0.0
def pixels(f):
    out = subprocess.run(["exrheader", f], capture_output=True, text=True).stdout
    for line in out.splitlines():
        if line.startswith("dataWindow"):
            v = [int(x) for x in re.findall(r"-?[0-9]+", line.split(":", 1)[1])]
            return (v[2] - v[0] + 1) * (v[3] - v[1] + 1)
    return 0
r = [num(f, "vsl.reference.spp") * pixels(f) / num(f, "vsl.reference.seconds") for f in sys.argv[1:]]
print("%.0f" % (sum(r) / len(r)))
EOF
)
    noise=$(python3 -c "print('%.4g' % ($(relmse "$a" "$b") / 4))")
    shipped=$(ls assets/references/"$name"-*-"${width}"x*-d64*.exr 2>/dev/null | head -1 || true)
    vsRef="n/a" refNoise="n/a"
    if [ -n "$shipped" ]; then
      refNoise=$(attr "$shipped" vsl.reference.indirectNoise)
      errs=""
      for r in "${runs[@]}"; do errs="$errs $(relmse "$r" "$shipped")"; done
      vsRef=$(python3 -c "
import statistics, sys
e = sorted(float(x) - $refNoise for x in '$errs'.split())
print('%.4g [%.4g, %.4g]' % (statistics.median(e), e[0], e[-1]))")
    fi
    printf "%s\t%s\t%s\t%s\t%s\t%s\t%s\n" "$name" "$method" "$spp" "$rate" "$noise" "$vsRef" "$refNoise"
  done
done
