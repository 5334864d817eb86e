# SPDX-License-Identifier: Apache-2.0
"""The functions that the installed public headers declare, for test/external/run.sh.

    python3 test/external/public_functions.py CC INCLUDE_DIR [HEADER ...]

Includes the headers of one library in one translation unit: the HEADERs, paths under INCLUDE_DIR (e.g.
tinyvo/port/png.h), or without any every header of the core, INCLUDE_DIR/tinyvo/*.h (the port layer's, in
tinyvo/port/, belong to libtinyvo_port and libtinyvo_v4l2). Preprocesses it with CC (C99, TVO_API defined
as a marker word: the compiler deals with the comments and #if branches) and reads the file-scope
declarations that come from those headers, not from the headers they include. Prints one line per
function with external linkage, sorted: "<name> marked" when its declaration carries TVO_API, "<name>
unmarked" otherwise. Left out: typedefs, variables, and static (inline) functions, which a library never
exports. Exit 1 when the preprocessor fails, when a HEADER does not exist, or when a TVO_API mark is not on
a function declaration this script recognises (so that a declaration it misreads cannot go unnoticed).
"""
from __future__ import annotations

import pathlib
import re
import subprocess
import sys

MARK = "tvo_api_mark_"
KEYWORDS = {
    "auto", "break", "case", "char", "const", "continue", "default", "do", "double", "else", "enum", "extern",
    "float", "for", "goto", "if", "inline", "int", "long", "register", "restrict", "return", "short",
    "signed", "sizeof", "static", "struct", "switch", "typedef", "union", "unsigned", "void", "volatile",
    "while", "_Bool", "_Complex", "_Imaginary",
}


def preprocessed(cc: str, include: pathlib.Path, names: list[str]) -> str:
    """The text of the headers (names under include; none: include/tinyvo/*.h) after preprocessing,
    without what other files bring."""
    headers = [include / n for n in names] if names else sorted(include.glob("tinyvo/*.h"))
    if not headers:
        sys.exit(f"public_functions.py: no header in {include}/tinyvo")
    for h in headers:
        if not h.is_file():
            sys.exit(f"public_functions.py: no header {h}")
    tu = "".join(f'#include "{h.relative_to(include).as_posix()}"\n' for h in headers)
    run = subprocess.run([cc, "-std=c99", "-E", f"-DTVO_API={MARK}", f"-I{include}", "-x", "c", "-"],
                         input=tu, capture_output=True, text=True, check=False)
    if run.returncode != 0:
        sys.stderr.write(run.stderr)
        sys.exit(f"public_functions.py: {cc} -E failed on the headers of {include}")
    wanted = {h.resolve() for h in headers}
    keep, out = False, []
    for line in run.stdout.splitlines():
        marker = re.match(r'#\s*(?:line\s+)?\d+\s+"(.*)"', line)
        if marker:
            keep = pathlib.Path(marker.group(1)).resolve() in wanted
        elif keep and not line.startswith("#"):
            out.append(line)
    return "\n".join(out)


def statements(text: str) -> list[str]:
    """File-scope declarations (up to ';' outside brackets) and function definitions (up to their '}')."""
    result, cur, depth, i = [], [], 0, 0
    while i < len(text):
        c = text[i]
        if c in "\"'":  # a literal: copied whole, its brackets and ';' do not count
            j = i + 1
            while j < len(text) and text[j] != c:
                j += 2 if text[j] == "\\" else 1
            cur.append(text[i:j + 1])
            i = j + 1
            continue
        cur.append(c)
        i += 1
        if c in "([{":
            depth += 1
        elif c in ")]}":
            depth -= 1
        if depth == 0 and c == ";":
            result.append("".join(cur))
            cur = []
        elif depth == 0 and c == "}":
            s = "".join(cur)
            if s[:s.index("{")].rstrip().endswith(")"):  # a function body, not a struct or enum
                result.append(s)
                cur = []
    return result


def declared(text: str) -> tuple[dict[str, bool], int]:
    """name -> marked, for the functions with external linkage; and the number of marks read."""
    functions: dict[str, bool] = {}
    marks = 0
    for s in statements(text):
        s = " ".join(s.split())
        words = re.findall(r"[A-Za-z_]\w*", s)
        if not words or words[0] == "typedef":
            continue
        # the declarator: the identifier before the first '(' outside brackets, e.g. "T *name(...)"
        depth, name, prefix = 0, None, ""
        for k, c in enumerate(s):
            if c == "(" and depth == 0:
                m = re.search(r"([A-Za-z_]\w*)\s*$", s[:k])
                if m:
                    name, prefix = m.group(1), s[:m.start()]
                break
            if c in "([{":
                depth += 1
            elif c in ")]}":
                depth -= 1
        pwords = re.findall(r"[A-Za-z_]\w*", prefix)
        if name is None or name in KEYWORDS or name == MARK or not pwords:
            continue  # not a function: a variable, a struct, a function pointer
        if "static" in pwords:
            continue
        marked = MARK in pwords
        marks += marked
        functions[name] = functions.get(name, False) or marked
    return functions, marks


def main() -> int:
    if len(sys.argv) < 3:
        sys.exit("usage: public_functions.py CC INCLUDE_DIR [HEADER ...]")
    text = preprocessed(sys.argv[1], pathlib.Path(sys.argv[2]), sys.argv[3:])
    functions, marks = declared(text)
    total = len(re.findall(rf"\b{MARK}\b", text))
    if marks != total:
        sys.exit(f"public_functions.py: {total} TVO_API marks in the headers, {marks} on function "
                 "declarations read here: a mark on something else, or a declaration this script misreads")
    for name in sorted(functions):
        print(name, "marked" if functions[name] else "unmarked")
    return 0


if __name__ == "__main__":
    sys.exit(main())
