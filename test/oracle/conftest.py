# SPDX-License-Identifier: Apache-2.0
"""Shared fixtures of the OpenCV oracle tests: the ctypes handle on the C core and the data folder."""
import ctypes
import os
import pathlib

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]


def _lib_path():
    build = pathlib.Path(os.environ.get("TVO_BUILD_DIR", ROOT / "build" / "release"))
    return build / "test" / "libtinyvo_py.so"


@pytest.fixture(scope="session")
def tvo():
    """The C core, built as test/libtinyvo_py.so in the build folder ($TVO_BUILD_DIR)."""
    path = _lib_path()
    if not path.exists():
        pytest.fail(f"{path} not built: run cmake --build first (or set TVO_BUILD_DIR)")
    return ctypes.CDLL(str(path))


@pytest.fixture(scope="session")
def data_dir():
    """../shared/data (or $TVO_DATA_DIR); tests that need it skip with a clear message without it."""
    d = pathlib.Path(os.environ.get("TVO_DATA_DIR", ROOT.parent / "shared" / "data"))
    if not (d / "euroc").is_dir():
        pytest.skip(f"shared EuRoC data not found at {d} (set TVO_DATA_DIR)")
    return d
