#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# The main job (README): installs what is needed, builds tinyvo, renders a short synthetic EuRoC-format
# sequence along a built-in trajectory (no external data needed), replays it through the VO with
# ground-truth step lengths, evaluates it (ATE/RPE, evo) and prints where the plots are.
# Usage: tools/run-demo.sh [FRAMES]      (default 300)
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"
FRAMES="${1:-300}"
bash tools/install-deps.sh
cmake -S . -B build/release -G Ninja -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build build/release -j2 >/dev/null
PY="$ROOT/.venv/bin/python"
OUT="$ROOT/out/demo"
mkdir -p "$OUT"
echo "== rendering $FRAMES synthetic frames -> $OUT/seq"
"$PY" -m tinyvo_tools.synth --out "$OUT/seq" --builtin handheld --frames "$FRAMES" --seed 1
echo "== replaying through tinyvo"
build/release/examples/replay/tvo_replay --euroc "$OUT/seq" --out "$OUT/traj.txt" --scale gt \
  --stats "$OUT/stats.json"
echo "== evaluating"
"$PY" -m tinyvo_tools.eval --est "$OUT/traj.txt" --gt "$OUT/seq" --out "$OUT/eval.json" --plots "$OUT/plots"
echo "== done: trajectory $OUT/traj.txt, stats $OUT/stats.json, metrics $OUT/eval.json, plots $OUT/plots/"
