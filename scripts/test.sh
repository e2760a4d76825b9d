#!/usr/bin/env bash
# Install what is missing, build, and run every test:
#   1. the release build (build/): all labels (unit, stats, render);
#   2. an address+undefined sanitizer build (build-asan/): all labels;
#   3. a thread sanitizer build (build-tsan/): all labels.
# Options: --quick runs only step 1. Remaining arguments go to ctest,
# e.g. scripts/test.sh --quick -L unit.
set -euo pipefail
cd "$(dirname "$0")/.."
quick=0
if [ "${1:-}" = "--quick" ]; then quick=1; shift; fi
scripts/setup.sh

run_suite() {  # build dir, cmake args...
  local dir=$1; shift
  echo "== $dir: build"
  BUILD_DIR=$dir scripts/build.sh "$@"
  echo "== $dir: test"
  (cd "$dir" && ctest --output-on-failure -j"$(nproc)" "${CTEST_ARGS[@]}")
}

CTEST_ARGS=("$@")
[ ${#CTEST_ARGS[@]} -gt 0 ] || CTEST_ARGS=(--timeout 900)
run_suite build -DVSL_SANITIZE=
if [ $quick -eq 0 ]; then
  run_suite build-asan -DVSL_SANITIZE=address
  run_suite build-tsan -DVSL_SANITIZE=thread
fi
echo "== all test suites passed"
