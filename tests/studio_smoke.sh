#!/usr/bin/env bash
# A real window under Xvfb: the studio starts on the default scene, renders
# frames, saves a screenshot that is not blank, and exits cleanly.
#   studio_smoke.sh VSL_STUDIO PNG_STATS OUT_DIR
set -euo pipefail
studio=$1 stats=$2 out=$3
mkdir -p "$out"
rm -f "$out/smoke.png"
# The studio restores and saves its last session: keep the user's own out of it.
export XDG_CONFIG_HOME="$out/config"
rm -rf "$XDG_CONFIG_HOME"
command -v xvfb-run >/dev/null || { echo "xvfb-run is missing: run scripts/setup.sh"; exit 1; }
xvfb-run -a -s "-screen 0 1280x800x24" "$studio" --frames 120 --screenshot "$out/smoke.png" --lights 300 --width 96 \
  2>&1 | tee "$out/smoke.log"
grep -q "frames, mean UI frame time" "$out/smoke.log" || { echo "the studio did not run in a window"; exit 1; }
"$stats" "$out/smoke.png" 10
