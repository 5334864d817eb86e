#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# The Python tools as a user installs them: `pip install ./tools` into a fresh venv, then every console
# script of tools/pyproject.toml ([project.scripts]) must answer --help (exit 0, first line
# "usage: <script> ...") and --version ("<script> <version>"). The venv is made with
# --system-site-packages so that Debian's python3-torch is visible (the [train] extra is not installed:
# PyPI's torch pulls GB of CUDA wheels); every other dependency comes from PyPI through the package's
# declared requirements (none from tools/requirements.txt), so a missing declaration fails here.
# Usage: tools/check-pip-install.sh [VENV_DIR]   (default build/pip-check; removed and made again)
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
VENV="$(realpath -m "${1:-$ROOT/build/pip-check}")"
PY="${TVO_PYTHON:-/usr/bin/python3}"
rm -rf "$VENV"
"$PY" -m venv --system-site-packages "$VENV"
# a copy of tools/: pip builds in place otherwise and leaves build/ and *.egg-info in the source tree
SRC="$(mktemp -d)"
trap 'rm -rf "$SRC"' EXIT
cp -r "$ROOT/tools/pyproject.toml" "$ROOT/tools/tinyvo_tools" "$SRC/"
echo "[pip-check] pip install ./tools into $VENV"
"$VENV/bin/python" -m pip install -q --disable-pip-version-check "$SRC"
version=$("$VENV/bin/python" -c "import importlib.metadata as m; print(m.version('tinyvo-tools'))")
mapfile -t scripts < <("$VENV/bin/python" - "$ROOT/tools/pyproject.toml" <<'PY'
import sys
try:
    import tomllib
except ModuleNotFoundError:  # Python < 3.11
    import tomli as tomllib
with open(sys.argv[1], "rb") as f:
    print("\n".join(tomllib.load(f)["project"]["scripts"]))
PY
)
[ ${#scripts[@]} -gt 0 ] || { echo "[pip-check] no console scripts declared" >&2; exit 1; }
fail=0
cd "$VENV" # not the source tree: the installed package must be what runs
for s in "${scripts[@]}"; do
  exe="$VENV/bin/$s"
  if [ ! -x "$exe" ]; then echo "[pip-check] FAIL $s: not installed" >&2; fail=1; continue; fi
  if ! out=$("$exe" --help 2>"$VENV/$s.err"); then
    echo "[pip-check] FAIL $s --help: exit status $?; $(tail -n 1 "$VENV/$s.err")" >&2; fail=1; continue
  fi
  case "$(head -n 1 <<<"$out")" in
    "usage: $s"*) ;;
    *) echo "[pip-check] FAIL $s --help: first line '$(head -n 1 <<<"$out")'" >&2; fail=1; continue ;;
  esac
  v=$("$exe" --version 2>&1) || true
  if [ "$v" != "$s $version" ]; then echo "[pip-check] FAIL $s --version: '$v'" >&2; fail=1; continue; fi
  echo "[pip-check] $s: --help and --version ok"
done
[ $fail -eq 0 ] || exit 1
echo "[pip-check] ${#scripts[@]} console scripts of tinyvo-tools $version installed by pip answer --help"

# the lazily imported dependencies too (scipy, evo, OpenCV, Pillow): a 5-frame synthetic sequence, its ground
# truth evaluated as an estimate (tinyvo-eval), and rendered with one track per frame (tinyvo-view)
T="$VENV/smoke"
mkdir -p "$T"
"$VENV/bin/tinyvo-synth" --out "$T/seq" --builtin line --frames 5 --quiet
"$VENV/bin/python" - "$T" <<'PY'
import sys
from tinyvo_tools import trajio
t = sys.argv[1]
gt = trajio.read_euroc_groundtruth(f"{t}/seq/mav0/state_groundtruth_estimate0/data.csv")
cam = trajio.read_sensor_yaml(f"{t}/seq/mav0/cam0/sensor.yaml")
trajio.write_tum(f"{t}/est.txt", gt.to_camera(cam.T_BS))
with open(f"{t}/tracks.csv", "w") as f:
    f.write("t_ns,id,x,y,age,flags\n")
    for k, tn in enumerate(gt.t_ns):
        f.write(f"{tn},1,{100 + 5 * k}.0,100.0,{k + 1},{3 | (4 if k == 0 else 0)}\n")
PY
"$VENV/bin/tinyvo-eval" --est "$T/est.txt" --gt "$T/seq" --out "$T/eval.json" --quiet
"$VENV/bin/tinyvo-view" --seq "$T/seq" --tracks "$T/tracks.csv" --traj "$T/est.txt" -o "$T/view.gif" --quiet
[ -s "$T/eval.json" ] && [ -s "$T/view.gif" ] || { echo "[pip-check] FAIL: no eval.json / view.gif" >&2; exit 1; }
echo "[pip-check] tinyvo-synth, tinyvo-eval and tinyvo-view ran from the installed package"
