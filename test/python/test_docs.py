# SPDX-License-Identifier: Apache-2.0
"""The product's documentation talks about the product, not about how it was developed.

README.md, CHANGELOG.md and every docs/*.md must not contain a commit hash, the word "session", an
issue number ("issue 7", "issues show 3"), "this machine" / "the development machine", or a path that
leaves the repository other than the data folder's documented default (../shared/data); and every
relative link in them must point at a file of the repository."""
import pathlib
import re

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
FILES = [ROOT / "README.md", ROOT / "CHANGELOG.md"] + sorted((ROOT / "docs").glob("*.md"))

# 7 to 40 lower-case hex digits standing alone, with at least one digit and one letter (a word such as
# "defaced" or a number such as 1403715273262142976 is not a hash); the mantissa of 1.5e-05 is not either
HEX = re.compile(r"(?<![0-9A-Za-z_.])([0-9a-f]{7,40})(?![0-9A-Za-z_])")
WORDS = [
    (re.compile(r"\bsessions?\b", re.I), "the word 'session'"),
    (re.compile(r"\bissues?\s*(show\s*)?#?\d+", re.I), "an issue number"),
    (re.compile(r"\bissues show\b", re.I), "'issues show'"),
    (re.compile(r"\b(this|the development) machine\b", re.I), "a machine of the development"),
]
UP = re.compile(r"(?:\.\./)+[\w./-]*")  # a relative path going up: must stay in the repository
LINK = re.compile(r"\]\(([^)#\s]+)(#[^)]*)?\)")


def hashes(text):
    out = []
    for m in HEX.finditer(text):
        tok = m.group(1)
        if not (re.search(r"\d", tok) and re.search(r"[a-f]", tok)):
            continue
        if re.fullmatch(r"\d+e", tok) and text[m.end():m.end() + 1] in "+-":
            continue
        out.append(tok)
    return out


def outside(path, text):
    """Relative paths in text (written in the file at path) that leave the repository, except the data
    folder's default, which is documented as ../shared/data beside the repository."""
    out = []
    for m in UP.finditer(text):
        target = m.group(0)
        if target.startswith("../shared/data"):
            continue
        full = (path.parent / target).resolve()
        if full != ROOT and ROOT not in full.parents:
            out.append(target)
    return out


def test_checker_catches_what_it_should():
    assert hashes("at commit 8c61616 and 5a08911") == ["8c61616", "5a08911"]
    assert hashes("fixed in 9ef99f3a0b1c2d3e4f5a6b7c8d9e0f1a2b3c4d5e") == ["9ef99f3a0b1c2d3e4f5a6b7c8d9e0f1a2b3c4d5e"]
    assert hashes("1403715273262142976.png, 1.76187114e-05, 0x1p512, defaced, 0xdeadbeef") == []
    for text in ["in session 14", "issue 5 asks", "(issues show 3)", "on this machine"]:
        assert any(rx.search(text) for rx, _ in WORDS), text
    assert outside(ROOT / "README.md", "see ../out/model/x and ../shared/DESIGN.md") == ["../out/model/x", "../shared/DESIGN.md"]
    assert outside(ROOT / "README.md", "TVO_DATA_DIR (default ../shared/data)") == []
    assert outside(ROOT / "docs" / "api.md", "[card](../models/MODEL_CARD.md), ../test/unit") == []


@pytest.mark.parametrize("path", FILES, ids=[str(p.relative_to(ROOT)) for p in FILES])
def test_no_development_history(path):
    text = path.read_text(encoding="utf-8")
    problems = [f"commit hash {h}" for h in hashes(text)]
    problems += [f"a path outside the repository: {t}" for t in outside(path, text)]
    for rx, what in WORDS:
        problems += [f"{what}: {m.group(0)!r}" for m in rx.finditer(text)]
    assert not problems, f"{path.relative_to(ROOT)}: " + "; ".join(problems)


@pytest.mark.parametrize("path", FILES, ids=[str(p.relative_to(ROOT)) for p in FILES])
def test_relative_links_resolve(path):
    text = path.read_text(encoding="utf-8")
    missing = []
    for m in LINK.finditer(text):
        target = m.group(1)
        if re.match(r"[a-z]+:", target):
            continue
        if not (path.parent / target).resolve().exists():
            missing.append(target)
    assert not missing, f"{path.relative_to(ROOT)}: links to missing files: {missing}"
