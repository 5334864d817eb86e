# SPDX-License-Identifier: Apache-2.0
"""No function in lib/src is 100 lines or longer, so that a reader sees each one on a screen.

The C code is clang-formatted with the repository's .clang-format (Linux braces): a function definition's
body opens with a `{` alone on a line at column 0 and closes with the next `}` alone at column 0. A
function's length is the number of lines from that `{` to that `}`, both included. Its name is the
identifier before the first `(` of the declaration that precedes the `{` (a block at column 0 that is
not a function, such as a struct closed by `};`, is skipped). Every lib/src/**/*.c and
lib/src/**/*.h is checked; the parser itself is checked on small synthetic sources first."""
import pathlib
import re

ROOT = pathlib.Path(__file__).resolve().parents[2]
LIMIT = 100  # a function of LIMIT lines or more fails
NAME = re.compile(r"([A-Za-z_]\w*)\s*\(")


def functions(text):
    """(name, first line (1-based, the `{`), length in lines) of every function definition in text."""
    lines = text.split("\n")
    out = []
    i = 0
    while i < len(lines):
        if lines[i] != "{":
            i += 1
            continue
        # the declaration: the lines above, back to the one that starts at column 0
        j = i - 1
        while j >= 0 and lines[j][:1] in (" ", "\t"):
            j -= 1
        signature = " ".join(lines[max(j, 0):i])
        close = i + 1
        while close < len(lines) and not lines[close].startswith("}"):
            close += 1
        if close == len(lines):
            raise ValueError("line %d: a `{` at column 0 without a `}` at column 0 after it" % (i + 1))
        m = NAME.search(signature)
        if m is not None and lines[close] == "}":
            out.append((m.group(1), i + 1, close - i + 1))
        i = close + 1
    return out


def long_functions(text, limit=LIMIT):
    return [(name, line, n) for name, line, n in functions(text) if n >= limit]


def test_parser_on_synthetic_source():
    body = lambda n: "{\n" + "    x++;\n" * (n - 2) + "}\n"  # a body of n lines, braces included
    src = ("/* a file */\n#include <x.h>\n\nstruct s\n{\n    int a;\n};\n\n"
           "static int short_one(int a)\n" + body(5) + "\n"
           "static void long_one(const double *a,\n                     double *b)\n" + body(100) + "\n"
           "int just_under(void)\n" + body(99) + "\n"
           "static const int table[] = {\n    1,\n};\n"
           "void *far(int a)\n" + body(130))
    assert functions(src) == [("short_one", 10, 5), ("long_one", 18, 100), ("just_under", 120, 99),
                              ("far", 224, 130)]
    assert [f[0] for f in long_functions(src)] == ["long_one", "far"]
    assert long_functions("int f(void)\n" + body(99)) == []
    assert long_functions("int f(void)\n" + body(100)) == [("f", 2, 100)]


def test_no_function_in_lib_src_is_100_lines_or_longer():
    files = sorted(p for p in (ROOT / "lib" / "src").rglob("*") if p.suffix in (".c", ".h"))
    assert len(files) > 10, "lib/src has too few C files: wrong root?"
    found = 0
    long = []
    for p in files:
        fns = functions(p.read_text())
        found += len(fns)
        long += ["%s:%d %s is %d lines" % (p.relative_to(ROOT), line, name, n)
                 for name, line, n in fns if n >= LIMIT]
    assert found > 100, "only %d functions found in lib/src: the parser does not see them" % found
    assert not long, "functions of %d lines or more (split them into named stages):\n  " % LIMIT + \
        "\n  ".join(long)
