#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# SPDX licence lines in the source files (docs/licence.md).
#   tools/spdx.sh --check   list the files without an SPDX-License-Identifier line; exit 1 if any
#   tools/spdx.sh --add     insert "SPDX-License-Identifier: <id>" as the first comment line of each of them
# Files: every .c .h .py .sh .cmake and CMakeLists.txt of the repository that git knows or would add
# (tracked, or untracked and not ignored). A file counts as licensed when one of its first 5 lines is a
# comment starting with "SPDX-License-Identifier: <id>" (any id: a file under another licence keeps its own).
# The line is a comment in the file's language: "/* ... */" in C, "# ..." elsewhere; a shebang line, and
# in Python a coding line (PEP 263) right after it, stay first. The identifier is $TVO_SPDX_ID
# (default Apache-2.0, the LICENSE at the root). Exit codes: 0 done / all licensed, 1 files lack it, 2 usage.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
ID="${TVO_SPDX_ID:-Apache-2.0}"
usage() { echo "usage: tools/spdx.sh --check | --add" >&2; exit 2; }
[ $# -eq 1 ] || usage
case "$1" in
  --check|--add) mode="$1" ;;
  -h|--help) # the comment block under the shebang, without an SPDX line
    awk 'NR > 1 && !/^#/ {exit} NR > 1 && !/SPDX-License-Identifier:/ {sub(/^# ?/, ""); print}' "${BASH_SOURCE[0]}"
    exit 0 ;;
  *) echo "tools/spdx.sh: unknown option $1" >&2; usage ;;
esac

cd "$ROOT"
SPDX_RE='^[[:space:]]*(#|//|/\*|\*)[[:space:]]*SPDX-License-Identifier:[[:space:]]*[A-Za-z0-9]'
missing=()
while IFS= read -r -d '' f; do
  case "$f" in
    *.c|*.h|*.py|*.sh|*.cmake|CMakeLists.txt|*/CMakeLists.txt) ;;
    *) continue ;;
  esac
  [ -f "$f" ] || continue # tracked but deleted in the working tree
  head -n 5 "$f" | grep -Eq "$SPDX_RE" && continue
  missing+=("$f")
done < <(git ls-files -z --cached --others --exclude-standard)

if [ "$mode" = --check ]; then
  if [ ${#missing[@]} -gt 0 ]; then
    echo "tools/spdx.sh: ${#missing[@]} file(s) without an SPDX-License-Identifier line (tools/spdx.sh --add):" >&2
    printf '  %s\n' "${missing[@]}" >&2
    exit 1
  fi
  echo "spdx: every source file has an SPDX-License-Identifier line"
  exit 0
fi

for f in "${missing[@]}"; do
  case "$f" in
    *.c|*.h) line="/* SPDX-License-Identifier: $ID */" ;;
    *) line="# SPDX-License-Identifier: $ID" ;;
  esac
  tmp="$(mktemp "$f.spdx.XXXXXX")"
  # keep: line 1 if it is a shebang; then, in Python, a coding declaration on the next line
  awk -v line="$line" -v py="$([[ "$f" == *.py ]] && echo 1 || echo 0)" '
    NR == 1 && /^#!/ { print; next }
    !done && py && NR <= 2 && /^[ \t\f]*#.*coding[:=]/ { print; next }
    !done { print line; done = 1 }
    { print }
    END { if (!done) print line }' "$f" > "$tmp"
  chmod --reference="$f" "$tmp"
  mv "$tmp" "$f"
  echo "spdx: $f"
done
echo "spdx: added the line to ${#missing[@]} file(s)"
