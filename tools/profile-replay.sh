#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Machine-independent cost of the VO and the replay's peak memory:
#   tools/profile-replay.sh EUROC_DIR [FRAMES] [REPLAY_BINARY]
# 1. instructions per frame: runs tvo_replay under `valgrind --tool=callgrind`, collecting only inside
#    tvo_vo_process (PNG decoding, file I/O and the trajectory output are excluded), and divides the
#    instruction count by the number of frames processed. Stable across runs and machine load; the
#    figure depends on the compiler and flags of the binary (default: build/release, gcc -O2/-O3).
# 2. peak RSS of a normal (not instrumented) replay of the same frames, from /usr/bin/time -v.
# Defaults: FRAMES 200, REPLAY build/release/examples/replay/tvo_replay.
# Environment: TVO_REPLAY_ARGS, extra tvo_replay arguments for both runs, split on spaces (e.g.
#   TVO_REPLAY_ARGS="--set lk.fb_levels=1 --set lk.win_size=15" to profile another configuration);
#   TVO_PROFILE_OUT=FILE keeps the callgrind output there (for callgrind_annotate --inclusive=yes).
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
SEQ="${1:?usage: tools/profile-replay.sh EUROC_DIR [FRAMES] [REPLAY_BINARY]}"
FRAMES="${2:-200}"
REPLAY="${3:-$ROOT/build/release/examples/replay/tvo_replay}"
for tool in valgrind callgrind_annotate /usr/bin/time; do
  command -v "$tool" >/dev/null || { echo "profile-replay: $tool not found (apt-get install valgrind time)" >&2; exit 2; }
done
[ -x "$REPLAY" ] || { echo "profile-replay: $REPLAY not built" >&2; exit 2; }
# shellcheck disable=SC2206  # split on purpose
EXTRA=(${TVO_REPLAY_ARGS:-})
TMP="$(mktemp -d)"
trap 'rm -rf "$TMP"' EXIT

valgrind --tool=callgrind --callgrind-out-file="$TMP/cg.out" --toggle-collect=tvo_vo_process \
  "$REPLAY" --euroc "$SEQ" --out "$TMP/traj.txt" --scale gt --max-frames "$FRAMES" --quiet \
  --stats "$TMP/stats.json" ${EXTRA[@]+"${EXTRA[@]}"} 2>"$TMP/valgrind.log"
processed=$(python3 -c "import json,sys; print(json.load(open(sys.argv[1]))['frames']['processed'])" "$TMP/stats.json")
total=$(callgrind_annotate "$TMP/cg.out" 2>/dev/null | awk '/PROGRAM TOTALS/ {gsub(",", "", $1); print $1; exit}')
[ -n "$total" ] && [ "$processed" -gt 0 ] || { echo "profile-replay: no callgrind total" >&2; exit 1; }
[ -z "${TVO_PROFILE_OUT:-}" ] || cp "$TMP/cg.out" "$TVO_PROFILE_OUT"

/usr/bin/time -v "$REPLAY" --euroc "$SEQ" --out "$TMP/traj2.txt" --scale gt --max-frames "$FRAMES" \
  --quiet ${EXTRA[@]+"${EXTRA[@]}"} 2>"$TMP/time.log"
rss_kb=$(awk -F: '/Maximum resident set size/ {gsub(/ /, "", $2); print $2}' "$TMP/time.log")

[ ${#EXTRA[@]} -eq 0 ] || echo "replay arguments:            ${EXTRA[*]}"
echo "frames processed:            $processed"
echo "instructions in tvo_vo_process: $total ($(( total / processed )) per frame)"
echo "top functions by self cost:"
callgrind_annotate "$TMP/cg.out" 2>/dev/null | awk '/file:function/ {on=1; getline; next} on && NF {print "  " $0; if (++k == 8) exit}'
echo "peak RSS of the replay:      ${rss_kb} kB"
