#!/usr/bin/env bash
# Install what is missing, build, and run the tests.
#
#   scripts/test.sh          what CI runs (.ci/run), about 20 minutes on 2 cores
#                            from a fresh clone:
#                            1. an address+undefined sanitizer build (build-asan/)
#                               of everything: every test;
#                            2. a thread sanitizer build (build-tsan/) of the
#                               suites that drive threads (TSAN_SUITES below):
#                               the session, the batches, parallel loops and
#                               their exceptions, the studio's frames.
#   scripts/test.sh --quick  the edit loop: the release build (build/), then
#                            every test not labelled `long` (about a minute
#                            once build/ exists).
#   scripts/test.sh --full   every test in all three builds (release, ASan+UBSan,
#                            TSan), about 45 minutes.
#   scripts/test.sh --monkey the studio under random input (tests/test_monkey.cpp)
#                            for VSL_MONKEY_SECONDS (default 600) in the
#                            ASan+UBSan build; VSL_MONKEY_SEED picks the run.
# The monkey test (label `monkey`) runs in --monkey only.
#
# Remaining arguments go to every ctest run, e.g. scripts/test.sh --quick -L unit.
# Each run writes ctest's JUnit file (<build dir>/junit.xml) and prints its ten
# slowest tests.
set -euo pipefail
cd "$(dirname "$0")/.."
mode=default
case "${1:-}" in
  --quick) mode=quick; shift ;;
  --full) mode=full; shift ;;
  --monkey) mode=monkey; shift ;;
  -h|--help) sed -n '2,24p' "$0"; exit 0 ;;
esac
scripts/setup.sh

# The GoogleTest binaries whose suites start, stop and join threads.
TSAN_SUITES=(test_session test_batches test_errors test_studio_frame)

# slowest DIR: the ten slowest tests of DIR's last run, from its JUnit file.
slowest() {
  python3 - "$1/junit.xml" <<'EOF' || true
import sys, xml.etree.ElementTree as ET
cases = [(float(c.get("time", 0)), c.get("name")) for c in ET.parse(sys.argv[1]).iter("testcase")]
print("   slowest:", ", ".join(f"{n} {t:.1f}s" for t, n in sorted(cases, reverse=True)[:10]))
EOF
}

# run_suite DIR [TARGETS...]: configure with CMAKE_ARGS, build the targets (or
# everything), run ctest with CTEST_ARGS.
run_suite() {
  local dir=$1; shift
  echo "== $dir: build"
  local start=$SECONDS
  cmake -S . -B "$dir" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DVSL_WERROR=ON "${CMAKE_ARGS[@]}" >/dev/null
  if [ $# -gt 0 ]; then
    cmake --build "$dir" -j"$(nproc)" --target "$@"
  else
    cmake --build "$dir" -j"$(nproc)"
  fi
  echo "== $dir: built in $((SECONDS - start)) s; test"
  start=$SECONDS
  (cd "$dir" && ctest --output-on-failure -j"$(nproc)" --output-junit junit.xml "${CTEST_ARGS[@]}")
  echo "== $dir: tested in $((SECONDS - start)) s"
  slowest "$dir"
}

USER_ARGS=("$@")
with_defaults() {  # the user's ctest arguments, or a per-test timeout
  CTEST_ARGS=("$@")
  [ ${#USER_ARGS[@]} -gt 0 ] && CTEST_ARGS+=("${USER_ARGS[@]}")
  CTEST_ARGS+=(--timeout 900)
}

# The default's sanitizer builds keep line tables only (-g1): their reports
# still name files and lines, and they build faster than with full -g.
LINES_ONLY="-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=-O2 -g1 -DNDEBUG"
FULL_DEBUG="-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=-O2 -g -DNDEBUG"
tsan_regex="^($(IFS='|'; echo "${TSAN_SUITES[*]}"))\\."

case $mode in
  quick)
    with_defaults -LE long
    CMAKE_ARGS=(-DVSL_SANITIZE= "$FULL_DEBUG" -DVSL_BUILD_BENCH=ON)
    run_suite build
    ;;
  default)
    with_defaults -LE monkey
    # bench/ and the monkey test are no default test's: the release builds
    # (--quick, --full) compile bench/, --monkey the monkey.
    CMAKE_ARGS=(-DVSL_SANITIZE=address "$LINES_ONLY" -DVSL_BUILD_BENCH=OFF -DVSL_BUILD_MONKEY=OFF)
    run_suite build-asan
    # The studio's command-line and last-session tests check options and
    # files in processes of their own; they run under ASan+UBSan.
    with_defaults -R "$tsan_regex" -E '\.(StudioCli|LastSession)\.'
    CMAKE_ARGS=(-DVSL_SANITIZE=thread "$LINES_ONLY")
    run_suite build-tsan "${TSAN_SUITES[@]}" vsl-studio
    ;;
  full)
    with_defaults -LE monkey
    for pair in build: build-asan:address build-tsan:thread; do
      CMAKE_ARGS=("-DVSL_SANITIZE=${pair#*:}" "$FULL_DEBUG" -DVSL_BUILD_BENCH=ON)
      run_suite "${pair%%:*}"
    done
    ;;
  monkey)
    export VSL_MONKEY_SECONDS=${VSL_MONKEY_SECONDS:-600}
    with_defaults -L monkey --verbose
    CMAKE_ARGS=(-DVSL_SANITIZE=address "$LINES_ONLY" -DVSL_BUILD_BENCH=OFF -DVSL_BUILD_MONKEY=ON)
    run_suite build-asan test_monkey vsl-studio
    ;;
esac
echo "== all test suites passed ($mode)"
