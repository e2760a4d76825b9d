#!/usr/bin/env bash
# Reproduces the "Cost growth" figures of docs/RESULTS.md: stage times
# and memory against triangle count (dense cornell-glossy, 10^3..10^6
# triangles) and virtual light count (10^3..10^6), with growth exponents.
#   bash scripts/measure-geometry.sh [OUT_DIR]        (default out/geometry)
# Environment: TRIS and LIGHTS (the grids); ESTIMATOR (vpl, the default, or
# vsl); GATHER (brute-force gather image side, default 32) and GATHER_LIGHTS
# (at most this many of the lights gathered, default 20000); MRCS (MRCS image
# side, default 64; 300 rows, 900 clusters); NICE (default 5); SCALE (the
# vsl_scale binary, default build/bin/vsl_scale).
# Writes OUT_DIR/dense-N.gltf (generated, ~40 MB at 10^6), one CSV per scene,
# all.csv and table.md (the tables and exponents for the doc).
# About 20 minutes on 2 shared cores; scenes and CSVs that exist are reused.
set -euo pipefail
cd "$(dirname "$0")/.."
OUT=${1:-out/geometry}
TRIS=${TRIS:-"1000 10000 100000 1000000"}
LIGHTS=${LIGHTS:-1000,10000,100000,1000000}
GATHER=${GATHER:-32}
GATHER_LIGHTS=${GATHER_LIGHTS:-20000}
MRCS=${MRCS:-64}
ESTIMATOR=${ESTIMATOR:-vpl}
NICE=${NICE:-5}
SCALE=${SCALE:-build/bin/vsl_scale}
[ -x "$SCALE" ] || bash scripts/build.sh
mkdir -p "$OUT"

start=$(date +%s)
for n in $TRIS; do
  scene="$OUT/dense-$n.gltf"
  [ -e "$scene" ] || nice -n "$NICE" python3 assets/generate_scenes.py --dense "$n" "$scene"
  csv="$OUT/dense-$n.csv"
  if [ ! -s "$csv" ]; then
    args=(--lights "$LIGHTS" --estimator "$ESTIMATOR" --gather-size "$GATHER" --gather-lights "$GATHER_LIGHTS"
      --mrcs-size "$MRCS")
    echo "== $SCALE $scene ${args[*]}"
    nice -n "$NICE" "$SCALE" "$scene" "${args[@]}" >"$csv.tmp"
    mv "$csv.tmp" "$csv"
  fi
done
echo "measured in $(($(date +%s) - start)) s"

# Tables and growth exponents: log t = a log(triangles) + b log(lights) + c by
# least squares over the grid, and the local slope over the last decade.
python3 - "$OUT" $TRIS <<'EOF'
import csv, math, os, sys
out, tris = sys.argv[1], sys.argv[2:]
rows = []
for n in tris:
    with open(os.path.join(out, "dense-%s.csv" % n)) as f:
        rows += [{k: (v if k in ("scene", "estimator") else float(v)) for k, v in r.items()} for r in csv.DictReader(f)]
with open(os.path.join(out, "all.csv"), "w") as f:
    w = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
    w.writeheader()
    w.writerows(rows)

def fit(key, use_n=True, use_l=True):
    """Least-squares exponents (a, b) of key ~ n^a L^b."""
    pts = [(math.log(r["triangles"]), math.log(r["lights"]), math.log(r[key])) for r in rows if r[key] > 0]
    cols = [lambda p: 1.0] + ([lambda p: p[0]] if use_n else []) + ([lambda p: p[1]] if use_l else [])
    k = len(cols)
    A = [[sum(ci(p) * cj(p) for p in pts) for cj in cols] + [sum(ci(p) * p[2] for p in pts)] for ci in cols]
    for i in range(k):  # Gauss-Jordan on the normal equations
        piv = A[i][i]
        A[i] = [x / piv for x in A[i]]
        for j in range(k):
            if j != i:
                A[j] = [x - A[j][i] * y for x, y in zip(A[j], A[i])]
    coef = [A[i][k] for i in range(k)]
    a = coef[1] if use_n else None
    b = coef[-1] if use_l else None
    return a, b

def last_decade(key, along):
    """Slope between the two largest values of `along`, the other variable at its largest."""
    other = "lights" if along == "triangles" else "triangles"
    decade = lambda x: round(math.log10(x))  # the grid's nominal value (10,003 lights is 10^4)
    top = max(decade(r[other]) for r in rows)
    pts = sorted((r[along], r[key]) for r in rows if decade(r[other]) == top)
    (x0, y0), (x1, y1) = pts[-2], pts[-1]
    return math.log(y1 / y0) / math.log(x1 / x0) if y0 > 0 and y1 > 0 else float("nan")

for r in rows:
    r["mpairs"] = r["gather_pairs"] / r["gather_s"] / 1e6
    r["ns_pair"] = r["gather_s"] / r["gather_pairs"] * 1e9
    r["cpu_ns_pair"] = r["gather_cpu_s"] / r["gather_pairs"] * 1e9
f = lambda x, d=2: "%.*f" % (d, x)
g = lambda x: "{:,}".format(int(x))
lines = ["| triangles | file MB | load s (CPU s) | load peak MB | scene MB | BVH build s (CPU s) | BVH MB |",
         "|---|---|---|---|---|---|---|"]
for n, name in zip(sorted({r["triangles"] for r in rows}), tris):
    r = next(r for r in rows if r["triangles"] == n)
    mb = os.path.getsize(os.path.join(out, "dense-%s.gltf" % name)) / 2**20
    lines.append("| %s | %s | %s (%s) | %s | %s | %s (%s) | %s |" % (
        g(n), f(mb, 1), f(r["load_s"], 3), f(r["load_cpu_s"], 3), f(r["load_peak_mb"], 1), f(r["scene_mb"], 1),
        f(r["build_s"], 3), f(r["build_cpu_s"], 3), f(r["bvh_mb"], 1)))
lines += ["", "| triangles | lights | trace s | k-NN s | trace + k-NN CPU s | lights MB | gather lights | gather Mpairs/s (CPU ns/pair) "
          "| MRCS s (CPU s) | MRCS rows / clusters / columns s | MRCS peak MB |", "|---|---|---|---|---|---|---|---|---|---|---|"]
for r in rows:
    lines.append("| %s | %s | %s | %s | %s | %s | %s | %s (%s) | %s (%s) | %s / %s / %s | %s |" % (
        g(r["triangles"]), g(r["lights"]), f(r["trace_s"], 3), f(r["knn_s"], 3), f(r["prepare_cpu_s"]),
        f(r["lights_mb"], 1), g(r["gather_lights"]), f(r["mpairs"], 1), f(r["cpu_ns_pair"], 0), f(r["mrcs_s"]),
        f(r["mrcs_cpu_s"]), f(r["mrcs_rows_s"]), f(r["mrcs_cluster_s"]), f(r["mrcs_columns_s"]),
        f(r["mrcs_peak_mb"], 0)))
lines += ["", "| stage | figure | exponent in triangles (fit) | last decade | exponent in lights (fit) | last decade |",
          "|---|---|---|---|---|---|"]
stages = [("load", "wall s", "load_s", False), ("load", "CPU s", "load_cpu_s", False),
          ("load", "peak MB", "load_peak_mb", False), ("load", "scene MB", "scene_mb", False),
          ("BVH build", "wall s", "build_s", False), ("BVH build", "CPU s", "build_cpu_s", False),
          ("BVH build", "MB", "bvh_mb", False),
          ("light tracing", "wall s", "trace_s", True), ("k-NN radii", "wall s", "knn_s", True),
          ("trace + k-NN", "CPU s", "prepare_cpu_s", True), ("lights + radii", "MB", "lights_mb", True),
          ("gather", "wall ns/pair", "ns_pair", True), ("gather", "CPU ns/pair", "cpu_ns_pair", True),
          ("MRCS", "wall s", "mrcs_s", True), ("MRCS", "CPU s", "mrcs_cpu_s", True),
          ("MRCS rows", "wall s", "mrcs_rows_s", True), ("MRCS clustering", "wall s", "mrcs_cluster_s", True),
          ("MRCS columns", "wall s", "mrcs_columns_s", True), ("MRCS", "peak MB", "mrcs_peak_mb", True)]
for name, what, key, ul in stages:
    a, b = fit(key, True, ul)
    lines.append("| %s | %s | %s | %s | %s | %s |" % (name, what, f(a), f(last_decade(key, "triangles")),
                 f(b) if ul else "-", f(last_decade(key, "lights")) if ul else "-"))
text = "\n".join(lines) + "\n"
open(os.path.join(out, "table.md"), "w").write(text)
print(text)
EOF
