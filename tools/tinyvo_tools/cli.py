# SPDX-License-Identifier: Apache-2.0
"""The command-line conventions every tinyvo tool follows (one module, so that they cannot drift):

- ``--help``: the help text on stdout, exit 0; ``--version``: "<program> <version>" on stdout, exit 0;
- usage errors (unknown option, bad or missing value): ONE line on stderr, "<program>: error: <message>"
  naming the option, exit 2;
- runtime errors (missing or unreadable file, bad content, a failing external program): ONE line on
  stderr, "<program>: error: <message>", exit 1, no traceback (``TINYVO_TRACEBACK=1`` shows it);
- ``--quiet``: no progress and no summary output; errors still go to stderr.

A tool builds its parser with ``parser(PROG, __doc__)`` and runs its body through ``run(PROG, body)``::

    def main(argv=None) -> int:
        ap = cli.parser("tinyvo-x", __doc__)
        ap.add_argument(...)
        a = ap.parse_args(argv)
        return cli.run(ap.prog, lambda: _main(a, ap))
"""
from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import zipfile
from typing import Callable, Optional

from . import __version__


class Failure(Exception):
    """A runtime error with a message for the user (exit status 1)."""


_NUMBER = re.compile(r"^-\d+$|^-\d*\.\d+(e[+-]?\d+)?$", re.IGNORECASE)


class _Parser(argparse.ArgumentParser):
    def error(self, message):  # usage error: one line, exit 2 (argparse prints the usage too)
        self.exit(2, f"{self.prog}: error: {message}\n")

    def _is_known(self, tok: str) -> bool:
        name = tok.split("=", 1)[0]
        opts = self._option_string_actions
        if name in opts:
            return True
        if not name.startswith("--") and name[:2] in opts:  # -ofile, -vq
            return True
        return self.allow_abbrev and name.startswith("--") and any(o.startswith(name) for o in opts)

    def parse_args(self, args=None, namespace=None):
        # An unknown option is reported before a missing required one (argparse checks the other way
        # round), so that the one-line message names the option the user mistyped.
        args = sys.argv[1:] if args is None else list(args)
        for tok in args:
            if tok == "--":
                break
            if tok.startswith("-") and len(tok) > 1 and not _NUMBER.match(tok) and not self._is_known(tok):
                self.error(f"unrecognized arguments: {tok}")
        return super().parse_args(args, namespace)


def parser(prog: str, doc: Optional[str], quiet: bool = True, **kw) -> argparse.ArgumentParser:
    """An ArgumentParser for console script `prog` with the help text `doc` (kept as written), the
    --version option and, unless quiet=False (the tool adds its own), --quiet."""
    ap = _Parser(prog=prog, description=doc, formatter_class=argparse.RawDescriptionHelpFormatter, **kw)
    ap.add_argument("--version", action="version", version=f"{prog} {__version__}",
                    help="print the program's version and exit")
    if quiet:
        ap.add_argument("--quiet", action="store_true", help="no progress or summary output (errors still go to stderr)")
    return ap


def split_passthrough(argv=None) -> tuple:
    """(the tool's arguments, the arguments after the first "--", passed on to another program) of argv
    (default: sys.argv[1:])."""
    argv = list(sys.argv[1:] if argv is None else argv)
    if "--" not in argv:
        return argv, []
    k = argv.index("--")
    return argv[:k], argv[k + 1:]


def _message(e: BaseException) -> str:
    if isinstance(e, ModuleNotFoundError):
        hint = ""
        if e.name == "torch":
            hint = " (training needs PyTorch: apt install python3-torch, or pip install 'tinyvo-tools[train]')"
        return f"needs the Python module {e.name!r}{hint}"
    if isinstance(e, OSError) and e.filename is not None:
        return f"{e.filename}: {e.strerror or e}"
    if isinstance(e, KeyError):
        return f"missing key {e.args[0]!r}" if e.args else "missing key"
    if isinstance(e, subprocess.CalledProcessError):
        cmd = e.cmd if isinstance(e.cmd, str) else " ".join(map(str, e.cmd))
        return f"{cmd} exited with status {e.returncode}"
    msg = " ".join(str(e).split())  # one line
    return msg or type(e).__name__


def run(prog: str, body: Callable[[], Optional[int]]) -> int:
    """body(), with the runtime errors a user can cause turned into one line on stderr and exit status 1.
    Usage errors raised by the parser (SystemExit 2) pass through. Returns body's status (None: 0)."""
    try:
        rc = body()
        return 0 if rc is None else int(rc)
    except KeyboardInterrupt:
        print(f"{prog}: interrupted", file=sys.stderr)
        return 130
    except (Failure, OSError, ValueError, KeyError, ImportError, RuntimeError, EOFError, zipfile.BadZipFile,
            subprocess.CalledProcessError) as e:
        if os.environ.get("TINYVO_TRACEBACK"):
            raise
        print(f"{prog}: error: {_message(e)}", file=sys.stderr)
        return 1


def log(quiet: bool, *args, **kw) -> None:
    """print(*args) unless quiet (for progress and summary lines)."""
    if not quiet:
        print(*args, **kw)
