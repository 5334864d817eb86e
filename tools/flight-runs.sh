#!/bin/bash
# SPDX-License-Identifier: Apache-2.0
# Replay a configuration over whole flights at several RANSAC seeds (the whole-flight condition of
# docs/rules.md, "A forty-sixth rule"; tools/flight-rule.py judges the runs).
#
#   tools/flight-runs.sh LABEL OUTDIR REPLAY FLIGHTS [--set NAME=VALUE ...]
#
# FLIGHTS: a folder of EuRoC/ASL sequences (each a folder holding mav0/, e.g. the whole-flight renders of
# docs/evaluation.md, "Long runs"); every one is replayed with --scale none at each seed of TVO_SEEDS
# (default "75 76 77 78 79"). For each run OUTDIR gets LABEL_<flight>_s<seed>.txt (the trajectory),
# .stats.json (tvo_replay --stats) and .eval.json (tinyvo_tools.eval --out). A run already in OUTDIR is kept.
set -euo pipefail
if [ $# -lt 4 ]; then
    sed -n '3,11p' "$0" >&2
    exit 2
fi
label=$1 out=$2 replay=$(realpath "$3") flights=$(realpath "$4")
shift 4
root=$(cd "$(dirname "$0")/.." && pwd)
py=${PYTHON:-python3}
[ -x "$root/.venv/bin/python" ] && py=${PYTHON:-$root/.venv/bin/python}
mkdir -p "$out"
out=$(realpath "$out")
found=0
for dir in "$flights"/*/; do
    [ -d "$dir/mav0" ] || continue
    found=1
    name=$(basename "$dir")
    for seed in ${TVO_SEEDS:-75 76 77 78 79}; do
        base=$out/${label}_${name}_s$seed
        [ -f "$base.eval.json" ] && continue
        "$replay" --euroc "$dir" --scale none --out "$base.txt" --stats "$base.stats.json" --quiet "$@" \
            --set relpose.seed="$seed"
        (cd "$root/tools" && "$py" -m tinyvo_tools.eval --est "$base.txt" --gt "$dir" --out "$base.eval.json.part" \
            >/dev/null)
        mv "$base.eval.json.part" "$base.eval.json"
    done
done
if [ "$found" = 0 ]; then
    echo "flight-runs: no sequence (a folder holding mav0/) in $flights" >&2
    exit 2
fi
