#!/usr/bin/env bash
# The main job: install what is missing, build, and render the default scene.
# Until the studio exists, this renders the default comparison headlessly and
# prints where the files are.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
scripts/build.sh
SCENE=${1:-assets/scenes/cornell-glossy.gltf}
mkdir -p out
name=$(basename "$SCENE" .gltf)
build/bin/vsl render "$SCENE" --method pt --spp "${SPP:-64}" -o "out/$name.exr" --png "out/$name.png" --json "out/$name.json"
echo
echo "Rendered $SCENE with the path-traced reference:"
echo "  out/$name.exr   multi-layer EXR (full, direct, indirect)"
echo "  out/$name.png   tone-mapped sRGB preview"
echo "  out/$name.json  statistics (paths/s, rays/s, rejected samples)"
