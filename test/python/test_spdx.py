# SPDX-License-Identifier: Apache-2.0
"""tools/spdx.sh on a scratch git repository: --check lists the source files without an SPDX line (exit 1),
--add inserts it in each language's comment syntax (shebang and Python coding line kept first, other
files untouched, modes kept), after which --check passes and a second --add changes nothing."""
import os
import pathlib
import shutil
import stat
import subprocess

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
FILES = {
    "a/x.c": "/* a C file */\nint x;\n",
    "a/x.h": "#ifndef X_H\n#define X_H\n#endif\n",
    "a/s.py": "#!/usr/bin/env python3\n# -*- coding: utf-8 -*-\n\"\"\"doc\"\"\"\nX = 1\n",
    "a/t.py": "\"\"\"module doc\"\"\"\nY = 2\n",
    "a/r.sh": "#!/bin/sh\necho hi\n",
    "a/m.cmake": "set(A 1)\n",
    "CMakeLists.txt": "project(x C)\n",
    "sub/CMakeLists.txt": "",
    "a/notes.txt": "not a source file\n",
    "a/has.c": "/* SPDX-License-Identifier: MIT */\nint y;\n",
}
EXPECT_FIRST = {
    "a/x.c": ["/* SPDX-License-Identifier: Apache-2.0 */", "/* a C file */"],
    "a/x.h": ["/* SPDX-License-Identifier: Apache-2.0 */", "#ifndef X_H"],
    "a/s.py": ["#!/usr/bin/env python3", "# -*- coding: utf-8 -*-", "# SPDX-License-Identifier: Apache-2.0", '"""doc"""'],
    "a/t.py": ["# SPDX-License-Identifier: Apache-2.0", '"""module doc"""'],
    "a/r.sh": ["#!/bin/sh", "# SPDX-License-Identifier: Apache-2.0", "echo hi"],
    "a/m.cmake": ["# SPDX-License-Identifier: Apache-2.0", "set(A 1)"],
    "CMakeLists.txt": ["# SPDX-License-Identifier: Apache-2.0", "project(x C)"],
    "sub/CMakeLists.txt": ["# SPDX-License-Identifier: Apache-2.0"],
}


def spdx(repo, *args):
    return subprocess.run(["bash", str(repo / "tools" / "spdx.sh"), *args], capture_output=True, text=True, cwd=repo)


def test_spdx_check_and_add(tmp_path):
    if shutil.which("git") is None:
        pytest.fail("git not found")
    repo = tmp_path / "r"
    (repo / "tools").mkdir(parents=True)
    shutil.copy(ROOT / "tools" / "spdx.sh", repo / "tools" / "spdx.sh")
    (repo / "tools" / "spdx.sh").write_text("#!/usr/bin/env bash\n# SPDX-License-Identifier: Apache-2.0\n" +
                                            (ROOT / "tools" / "spdx.sh").read_text().split("\n", 1)[1])
    for rel, text in FILES.items():
        p = repo / rel
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_text(text)
    os.chmod(repo / "a/r.sh", 0o755)
    subprocess.run(["git", "init", "-q", str(repo)], check=True)
    (repo / "ignored").mkdir()
    (repo / "ignored" / "i.c").write_text("int i;\n")
    (repo / ".gitignore").write_text("/ignored/\n")

    r = spdx(repo, "--check")
    assert r.returncode == 1
    listed = sorted(l.strip() for l in r.stderr.splitlines()[1:])
    assert listed == sorted(EXPECT_FIRST), r.stderr  # not notes.txt, has.c, ignored/, tools/spdx.sh

    r = spdx(repo, "--add")
    assert r.returncode == 0, r.stderr
    for rel, first in EXPECT_FIRST.items():
        lines = (repo / rel).read_text().splitlines()
        assert lines[:len(first)] == first, (rel, lines)
        # nothing else changed: without the SPDX line the file is what it was
        rest = [l for l in (repo / rel).read_text().splitlines(keepends=True) if "SPDX-License-Identifier" not in l]
        assert "".join(rest) == FILES[rel], rel
    assert (repo / "a/notes.txt").read_text() == FILES["a/notes.txt"]
    assert (repo / "a/has.c").read_text() == FILES["a/has.c"]
    assert (repo / "ignored" / "i.c").read_text() == "int i;\n"
    assert stat.S_IMODE(os.stat(repo / "a/r.sh").st_mode) == 0o755
    assert subprocess.run(["sh", str(repo / "a/r.sh")], capture_output=True, text=True).stdout == "hi\n"

    assert spdx(repo, "--check").returncode == 0
    before = {rel: (repo / rel).read_text() for rel in EXPECT_FIRST}
    r = spdx(repo, "--add")
    assert r.returncode == 0 and "to 0 file(s)" in r.stdout
    assert before == {rel: (repo / rel).read_text() for rel in EXPECT_FIRST}

    assert spdx(repo).returncode == 2
    assert spdx(repo, "--bogus").returncode == 2
    h = spdx(repo, "--help")
    assert h.returncode == 0 and h.stdout.startswith("SPDX licence lines") and "SPDX-License-Identifier: Apache" not in h.stdout
