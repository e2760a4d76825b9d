#!/usr/bin/env bash
# Configures and builds into build/ (RelWithDebInfo, warnings as errors).
# Extra arguments go to CMake, e.g. scripts/build.sh -DVSL_SANITIZE=address.
# BUILD_DIR overrides the build directory.
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD_DIR=${BUILD_DIR:-build}
cmake -S . -B "$BUILD_DIR" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DVSL_WERROR=ON "$@" >/dev/null
cmake --build "$BUILD_DIR" -j"$(nproc)"
