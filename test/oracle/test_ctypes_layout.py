# SPDX-License-Identifier: Apache-2.0
"""The ctypes mirrors of the C config structs that the oracle tests hand to the library are at least as
large as the C structs: each *_config_default() writes into a buffer the size of the mirror followed by
a guard band, and the guard band must stay untouched. A mirror that misses a field added to a header
would otherwise let the library write past the Python object and corrupt the interpreter's heap (a
crash far from the cause)."""
import ctypes

import pytest

from test_ba_oracle import Config as BaConfig
from test_corners_oracle import TvoDetectConfig
from test_lk_oracle import LKConfig
from test_pnp_oracle import PnpConfig
from test_relpose_oracle import RelposeConfig

GUARD = 256
MIRRORS = [
    ("tvo_pnp_config_default", PnpConfig),
    ("tvo_lk_config_default", LKConfig),
    ("tvo_relpose_config_default", RelposeConfig),
    ("tvo_ba_config_default", BaConfig),
    ("tvo_detect_config_default", TvoDetectConfig),
]


@pytest.mark.parametrize("fn,mirror", MIRRORS, ids=[m[0] for m in MIRRORS])
def test_mirror_covers_the_c_struct(tvo, fn, mirror):
    n = ctypes.sizeof(mirror)
    buf = ctypes.create_string_buffer(b"\xa5" * (n + GUARD), n + GUARD)
    f = getattr(tvo, fn)
    f.restype = None
    f.argtypes = [ctypes.c_void_p]
    f(ctypes.addressof(buf))
    assert buf.raw[n:] == b"\xa5" * GUARD, f"{fn} wrote past the {n}-byte mirror {mirror.__name__}: add the new fields"
    # ...and the default touched the mirror's bytes (a wrong function name or an empty default would not)
    assert buf.raw[:n] != b"\xa5" * n
