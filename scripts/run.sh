#!/usr/bin/env bash
# The main job: install what is missing, build, and open vsl-studio on the
# bundled default scene. Without a display the studio says so, renders the
# default comparison (VSL, clamped VPL, path-traced reference) headlessly and
# exports it to out/studio/. Extra arguments go to vsl-studio, e.g.
# scripts/run.sh assets/scenes/kitchen.gltf --lights 20000
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
scripts/build.sh
exec build/bin/vsl-studio "$@"
