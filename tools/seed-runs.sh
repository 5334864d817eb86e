#!/bin/bash
# SPDX-License-Identifier: Apache-2.0
# Replay a configuration with 5 RANSAC seeds on the accuracy sequences of docs/rules.md (the second rule).
#
#   tools/seed-runs.sh LABEL OUTDIR REPLAY RENDERS [--set NAME=VALUE ...]
#
# LABEL: a name for the configuration; OUTDIR/LABEL_s<seed>.json is the suite's JSON for each seed and
# OUTDIR/LABEL_s<seed>_<sequence>.txt the trajectories of the two EuRoC samples. RENDERS: the folder of the
# 8 renders along the EuRoC trajectories (docs/evaluation.md). Sequences come from $TVO_DATA_DIR (default:
# ../shared/data beside the repository). A run already in OUTDIR is kept. tools/seed-rule.py compares.
# TVO_SEEDS="5 6 7 8 9" replaces the 5 seeds (default "24301 1 2 3 4"; give seed-rule.py the same).
set -euo pipefail
if [ $# -lt 4 ]; then
    sed -n '3,10p' "$0" >&2
    exit 2
fi
label=$1 out=$2 replay=$(realpath "$3") renders=$4
shift 4
root=$(cd "$(dirname "$0")/.." && pwd)
data=${TVO_DATA_DIR:-$root/../shared/data}
py=${PYTHON:-python3}
[ -x "$root/.venv/bin/python" ] && py=${PYTHON:-$root/.venv/bin/python}
seqs=()
for s in kitti07_160 kitti06_51 kitti01_51; do seqs+=(--seq "$data/kitti/$s"); done
for s in MH_01 MH_02 MH_03 MH_04 V1_01 V1_02 V2_01 V2_03; do seqs+=(--seq "$renders/$s"); done
mkdir -p "$out"
for seed in ${TVO_SEEDS:-24301 1 2 3 4}; do
    base=$out/${label}_s$seed
    [ -f "$base.json" ] && continue
    (cd "$root/tools" && "$py" -m tinyvo_tools.suite --replay "$replay" "${seqs[@]}" --scale none \
        --out "$base.json.part" --quiet -- "$@" --set relpose.seed=$seed)
    for e in V1_01_easy_head V1_01_easy_keyframes; do
        "$replay" --euroc "$data/euroc/$e" --scale none --out "${base}_$e.txt" --stats "${base}_$e.stats.json" \
            --quiet "$@" --set relpose.seed=$seed 2>/dev/null
    done
    mv "$base.json.part" "$base.json"
done
