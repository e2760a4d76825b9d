#!/usr/bin/env bash
# Builds the libFuzzer targets (tests/fuzz) with clang, ASan and UBSan into
# build-fuzz/ (or $BUILD_DIR) and runs them.
#   scripts/fuzz.sh                  the CTest label `fuzz`: loader 40 s, EXR 20 s
#   scripts/fuzz.sh loader 600       one target for 600 s (corpus in build-fuzz/tests/fuzz/)
# Exit status 0: nothing found. Reproducers (crash-*, leak-*, oom-*, timeout-*)
# are written next to the working corpus; replay one with
#   build-fuzz/bin/fuzz_loader FILE
set -euo pipefail
cd "$(dirname "$0")/.."
B=${BUILD_DIR:-build-fuzz}
scripts/setup.sh --fuzz
CLANG=$(command -v clang-14 || command -v clang)
CLANGXX=$(command -v clang++-14 || command -v clang++)
cmake -S . -B "$B" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_C_COMPILER="$CLANG" \
  -DCMAKE_CXX_COMPILER="$CLANGXX" -DVSL_FUZZ=ON -DVSL_SANITIZE=address -DVSL_BUILD_UI=OFF -DVSL_WERROR=ON >/dev/null
cmake --build "$B" -j"$(nproc)" --target fuzz_loader fuzz_exr
if [ $# -ge 1 ]; then
  target=$1 seconds=${2:-600}
  work=$B/tests/fuzz/corpus-$target
  exec env ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
    tests/fuzz/run_fuzzer.sh "$B/bin/fuzz_$target" "$work" "tests/fuzz/corpus/$target" "$seconds"
fi
cd "$B" && ctest -L fuzz --output-on-failure
