#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Fuzzes tinyvo's parsers and the VO with libFuzzer (clang), one harness at a time (docs/fuzzing.md).
#
#   tools/run-fuzz.sh [-t SECONDS] [HARNESS...]     HARNESS: nn csv yaml png dataset vo (default: all)
#
# Installs clang and libclang-rt-14-dev (libFuzzer, sanitizer runtimes) when missing (as root, after
# apt-get update), builds build/fuzz with -DTVO_BUILD_FUZZ=ON (libFuzzer + ASan + UBSan), then runs
# each harness for SECONDS (default 600) with -jobs=1. Seeds come from test/fuzz/corpus/<name>/ (read
# only); inputs the fuzzer finds go to build/fuzz/work/<name>/; crash, leak and timeout inputs are
# written into test/fuzz/corpus/<name>/ so that they become ctest regression cases once committed.
# At the end it prints, per harness, executions, execs/s, coverage (cov: edges, ft: features) and
# the number of new crash inputs; the full libFuzzer log is build/fuzz/logs/<name>/fuzz-0.log.
# Exit status 1 when any harness left a crash input.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"

SECONDS_EACH=600
while getopts "t:h" opt; do
  case $opt in
    t) SECONDS_EACH=$OPTARG ;;
    *) sed -n '3,14p' "$0"; exit 2 ;;
  esac
done
shift $((OPTIND - 1))
HARNESSES=("$@")
[ ${#HARNESSES[@]} -gt 0 ] || HARNESSES=(nn csv yaml png dataset vo)

# max_len per harness: the largest input worth mutating (a weights file with a few small branches, a
# few hundred csv rows / yaml lines, a small PNG, a header + a few 96x96 frames)
declare -A MAX_LEN=([nn]=16384 [csv]=4096 [yaml]=4096 [png]=16384 [dataset]=4096 [vo]=32768)

# ---- tools ----------------------------------------------------------------------------------------
. "$ROOT/tools/apt-lib.sh"
tvo_apt_ensure run-fuzz clang libclang-rt-14-dev cmake ninja-build libspng-dev || exit 1

# ---- build ----------------------------------------------------------------------------------------
BUILD="$ROOT/build/fuzz"
cmake -S . -B "$BUILD" -G Ninja -DCMAKE_C_COMPILER=clang -DCMAKE_BUILD_TYPE=RelWithDebInfo \
      -DTVO_BUILD_FUZZ=ON -DTVO_BUILD_TESTS=OFF -DTVO_BUILD_EXAMPLES=OFF -DTVO_BUILD_BENCH=OFF \
      -DTVO_WITH_V4L2=OFF >/dev/null
cmake --build "$BUILD" -j2

# ---- fuzz -----------------------------------------------------------------------------------------
summary=()
failed=0
for h in "${HARNESSES[@]}"; do
  [ -n "${MAX_LEN[$h]:-}" ] || { echo "[run-fuzz] unknown harness '$h'" >&2; exit 2; }
  exe="$BUILD/test/fuzz/fuzz_$h"
  seeds="$ROOT/test/fuzz/corpus/$h"
  work="$BUILD/work/$h"
  logs="$BUILD/logs/$h"
  mkdir -p "$work" "$logs"
  rm -f "$logs"/fuzz-*.log
  before=$(find "$seeds" -maxdepth 1 -type f \( -name 'crash-*' -o -name 'leak-*' -o -name 'timeout-*' -o -name 'oom-*' \) | wc -l)
  echo "== fuzz_$h: ${SECONDS_EACH} s, max_len ${MAX_LEN[$h]}"
  start=$(date +%s)
  # libFuzzer exits non-zero on a crash: record it and go on with the next harness
  (cd "$logs" && ASAN_OPTIONS=detect_leaks=1:abort_on_error=0 UBSAN_OPTIONS=print_stacktrace=1 \
     "$exe" "$work" "$seeds" -jobs=1 -workers=1 -max_total_time="$SECONDS_EACH" -max_len="${MAX_LEN[$h]}" \
       -rss_limit_mb=2048 -timeout=30 -print_final_stats=1 -artifact_prefix="$seeds/" >/dev/null 2>&1) || true
  secs=$(( $(date +%s) - start ))
  log="$logs/fuzz-0.log"
  after=$(find "$seeds" -maxdepth 1 -type f \( -name 'crash-*' -o -name 'leak-*' -o -name 'timeout-*' -o -name 'oom-*' \) | wc -l)
  last=$(grep -E '^#[0-9]+' "$log" | grep 'cov:' | tail -1 || true)
  execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -1)
  rate=$(sed -n 's/^stat::average_exec_per_sec: *//p' "$log" | tail -1)
  cov=$(echo "$last" | sed -n 's/.*cov: \([0-9]*\).*/\1/p')
  ft=$(echo "$last" | sed -n 's/.* ft: \([0-9]*\).*/\1/p')
  corp=$(echo "$last" | sed -n 's/.* corp: \([0-9]*\/[0-9a-zA-Z]*\).*/\1/p')
  new=$((after - before))
  [ "$new" -eq 0 ] || failed=1
  grep -E 'ERROR: |runtime error|fuzz invariant failed' "$log" | head -5 || true
  summary+=("$(printf '%-9s %6s %12s %9s %7s %7s %12s %8s' "fuzz_$h" "$secs" "${execs:-?}" "${rate:-?}" \
               "${cov:-?}" "${ft:-?}" "${corp:-?}" "$new")")
done

echo
printf '%-9s %6s %12s %9s %7s %7s %12s %8s\n' harness seconds execs exec/s cov ft corpus crashes
for line in "${summary[@]}"; do echo "$line"; done
[ "$failed" -eq 0 ] || echo "[run-fuzz] new crash inputs in test/fuzz/corpus/<name>/ (logs in build/fuzz/logs/)"
exit "$failed"
