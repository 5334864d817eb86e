#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Installs what tinyvo needs on a fresh Debian (bookworm) machine, idempotently:
#   - Debian packages (apt-get update first; only when running as root and something is missing)
#   - a Python venv in .venv with the pinned tools/requirements.txt and the tools package
# Usage: tools/install-deps.sh          (from anywhere)
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"

APT_PACKAGES=(
  build-essential cmake ninja-build pkg-config git
  libcmocka-dev libspng-dev libpng-dev libv4l-dev
  python3 python3-venv python3-pip python3-torch
  valgrind
)
. "$ROOT/tools/apt-lib.sh"
tvo_apt_ensure install-deps "${APT_PACKAGES[@]}" || exit 1

VENV="$ROOT/.venv"
STAMP="$VENV/.tvo-requirements"
if [ ! -x "$VENV/bin/python" ]; then
  /usr/bin/python3 -m venv --system-site-packages "$VENV"
fi
if [ ! -f "$STAMP" ] || ! cmp -s "$ROOT/tools/requirements.txt" "$STAMP"; then
  echo "[install-deps] pip install -r tools/requirements.txt"
  "$VENV/bin/python" -m pip install -q --disable-pip-version-check -r "$ROOT/tools/requirements.txt"
  cp "$ROOT/tools/requirements.txt" "$STAMP"
fi
if [ -f "$ROOT/tools/pyproject.toml" ]; then
  "$VENV/bin/python" -m pip install -q --disable-pip-version-check --no-deps --no-build-isolation -e "$ROOT/tools" >/dev/null
fi
