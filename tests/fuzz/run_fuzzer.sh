#!/usr/bin/env bash
# run_fuzzer.sh FUZZER WORK_CORPUS SEED_CORPUS SECONDS
# Runs a libFuzzer target for SECONDS over a working copy of the seed corpus
# (new inputs land in the copy), with memory and per-input time limits.
# Exit status: libFuzzer's (0 = nothing found). Crash reproducers are written
# to WORK_CORPUS/../ as crash-*, leak-*, oom-* or timeout-*.
set -euo pipefail
fuzzer=$(realpath "$1") work=$(realpath -m "$2") seeds=$(realpath "$3") seconds=$4
mkdir -p "$work"
cp -n "$seeds"/* "$work"/ 2>/dev/null || true
cd "$(dirname "$work")"
exec "$fuzzer" "$work" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2560 -malloc_limit_mb=2048 \
  -max_len=262144 -print_final_stats=1
