#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Retrain the shipped step-length model (models/MODEL_CARD.md) for the current front end, and measure it:
#   tools/retrain-step-model.sh RENDERS_DIR OUT_DIR [REPLAY_BINARY]
#
# RENDERS_DIR holds the eight rendered EuRoC sequences by name (MH_01 MH_02 MH_03 MH_04 V1_01 V1_02 V2_01
# V2_03); a missing one is rendered first with the card's settings (tinyvo_tools.synth along
# $TVO_DATA_DIR/euroc/groundtruth/<NAME>.csv, 640 frames from the start time below, seed 0; about 2-8 minutes of
# one core each). REPLAY_BINARY: tvo_replay of the front end the model is for (default
# build/release/examples/replay/tvo_replay). Everything is written under OUT_DIR (must not exist yet or be
# empty): nothing in the repository changes. Steps (the card's recipe; the split: training MH_01 MH_02 MH_03
# V1_01 V2_01, validation MH_04 V1_02 V2_03):
#   1. dataset: tvo_replay --features on the eight sequences (tinyvo_tools.dataset)
#   2. train: one relu ln |t| branch, 11 -> 256 -> 32 -> 32 -> 1, 40 + 10 epochs, lr 1e-3, seed 0, input
#      domain 2 %, on the training sequences only (tinyvo_tools.train; the recipe tinyvo_tools.steprules
#      judges its choices with)
#   3. clip the step branch's hidden relus at their layer's training maximum (tinyvo_tools.pact)
#   4. export to int8 with hidden-channel copies 1,1,2 (tinyvo_tools.export): OUT_DIR/step.tvonn
#   5. evaluate on the validation sequences through the C interpreter (tinyvo_tools.suite, ATE SE(3),
#      tvo_replay's defaults, i.e. with the local map): the model as the scale source with the filter
#      a = 0.01 (the shipped use) and alone, the constant training-mean step and ground-truth step
#      lengths as the scale source; OUT_DIR/summary.md has the table.
# Deterministic: the same renders and front end give a byte-identical step.tvonn.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
RENDERS="${1:?usage: tools/retrain-step-model.sh RENDERS_DIR OUT_DIR [REPLAY_BINARY]}"
OUT="${2:?usage: tools/retrain-step-model.sh RENDERS_DIR OUT_DIR [REPLAY_BINARY]}"
REPLAY="${3:-$ROOT/build/release/examples/replay/tvo_replay}"
PY="$ROOT/.venv/bin/python"
DATA="${TVO_DATA_DIR:-$ROOT/../shared/data}"
TRAIN="MH_01 MH_02 MH_03 V1_01 V2_01"
VAL="MH_04 V1_02 V2_03"
# start times (s): where the drone starts to fly (after the still part at the start; MH: after the
# hand-held shake and the rest on the floor); 640 frames at 20 Hz = 32 s
declare -A START=([MH_01]=43.2 [MH_02]=37.4 [MH_03]=16.6 [MH_04]=18.5 [V1_01]=4.9 [V1_02]=3.2 [V2_01]=2.9 [V2_03]=3.9)
declare -A GT=([MH_01]=MH_01_easy [MH_02]=MH_02_easy [MH_03]=MH_03_medium [MH_04]=MH_04_difficult
               [V1_01]=V1_01_easy [V1_02]=V1_02_medium [V2_01]=V2_01_easy [V2_03]=V2_03_difficult)

[ -x "$REPLAY" ] || { echo "retrain-step-model: $REPLAY not built" >&2; exit 2; }
[ -x "$PY" ] || { echo "retrain-step-model: $PY missing (bash tools/install-deps.sh)" >&2; exit 2; }
if [ -e "$OUT" ] && [ -n "$(ls -A "$OUT")" ]; then
  echo "retrain-step-model: $OUT is not empty" >&2; exit 2
fi
mkdir -p "$OUT" "$RENDERS"
OUT="$(cd "$OUT" && pwd)"; RENDERS="$(cd "$RENDERS" && pwd)"; REPLAY="$(cd "$(dirname "$REPLAY")" && pwd)/$(basename "$REPLAY")"
cd "$ROOT/tools"
T0=$(date +%s)
step() { echo "== $(( $(date +%s) - T0 )) s: $*" | tee -a "$OUT/log.txt"; }

for s in $TRAIN $VAL; do
  if [ ! -f "$RENDERS/$s/mav0/cam0/data.csv" ]; then
    step "render $s (start ${START[$s]} s, 640 frames)"
    "$PY" -m tinyvo_tools.synth --quiet --out "$RENDERS/$s" --trajectory "$DATA/euroc/groundtruth/${GT[$s]}.csv" \
        --start-time "${START[$s]}" --frames 640
  fi
done

step "1. dataset"
"$PY" -m tinyvo_tools.dataset $(for s in $TRAIN $VAL; do echo "$RENDERS/$s"; done) \
    -o "$OUT/dataset.npz" --replay "$REPLAY" --work "$OUT/features" >> "$OUT/log.txt"

step "2. train"
"$PY" -m tinyvo_tools.train "$OUT/dataset.npz" -o "$OUT/train.ckpt.npz" --act relu --dofs log_step \
    --val-sequences "${VAL// /,}" --epochs 40 --joint-epochs 10 --lr 1e-3 --seed 0 --input-clip 2 \
    >> "$OUT/log.txt" 2>&1

step "3. clip the relu layers (pact)"
"$PY" -m tinyvo_tools.pact "$OUT/train.ckpt.npz" "$OUT/dataset.npz" -o "$OUT/step.ckpt.npz" \
    >> "$OUT/log.txt"

step "4. export (copies 1,1,2)"
"$PY" -m tinyvo_tools.export "$OUT/step.ckpt.npz" "$OUT/dataset.npz" -o "$OUT/step.tvonn" \
    --hidden-copies 1,1,2 > "$OUT/export.json"

step "5. evaluate on $VAL"
# the constant step: the mean ground-truth step over the training rows (as tinyvo_tools.tables' prior)
CONST=$("$PY" -c "import sys, numpy as np; from tinyvo_tools import train
f, t, seq = train.load_dataset(sys.argv[1])
print(repr(float(np.linalg.norm(t[np.isin(seq, sys.argv[2:]), :3], axis=1).mean())))" "$OUT/dataset.npz" $TRAIN)
SEQS=$(for s in $VAL; do echo "--seq $RENDERS/$s"; done)
suite() {  # NAME SCALE [-- extra]
  local name=$1 scale=$2; shift 2
  "$PY" -m tinyvo_tools.suite --replay "$REPLAY" $SEQS --scale "$scale" --out "$OUT/eval_$name.json" "$@" \
      > "$OUT/eval_$name.txt"
}
suite model_filter model -- --model "$OUT/step.tvonn" --scale-alpha 0.01
suite model_alone model -- --model "$OUT/step.tvonn"
suite const_step const -- --step "$CONST"
suite gt_scale gt

"$PY" - "$OUT" "$CONST" <<'EOF' | tee "$OUT/summary.md"
import json, sys
out, const = sys.argv[1], float(sys.argv[2])
ex = json.load(open(f"{out}/export.json"))
rows = [("model + filter a = 0.01 (shipped use)", "model_filter"), ("model alone (--scale model)", "model_alone"),
        (f"constant step {const:.4f} m (training mean)", "const_step"), ("ground-truth step lengths", "gt_scale")]
res = {k: json.load(open(f"{out}/eval_{k}.json")) for _, k in rows}
names = [r["name"] for r in res["gt_scale"]["sequences"]]
print("ATE SE(3) RMSE, m, validation sequences, by scale source (tvo_replay through the C interpreter; "
      "tinyvo_tools.suite)\n")
print("| method | " + " | ".join(names) + " | mean |")
print("|---|" + "---|" * (len(names) + 1))
for label, k in rows:
    seqs = {r["name"]: r for r in res[k]["sequences"]}
    v = [seqs[n].get("ate_m", float("nan")) for n in names]
    print(f"| {label} | " + " | ".join(f"{x:.3f}" for x in v) + f" | {sum(v) / len(v):.3f} |")
d = ex["per_dof"]["log_step"] if "log_step" in ex["per_dof"] else next(iter(ex["per_dof"].values()))
print(f"\nint8 vs float on the {ex.get('eval_split', 'validation')} rows: {100 * ex['worst_rms_diff_over_std']:.2f} % of "
      f"the step's std; {ex['bytes']} bytes, {ex['macs']} MACs per frame")
EOF
step "done: $OUT/step.tvonn (copy it over models/tinyvo_synth_euroc_logstep_relu.tvonn to ship it)"
