"""keep_freed_memory: after it, glibc serves a frame-sized block from its heap instead of a
fresh mapping (the pages a writer frees stay with the process for its next frames)."""

from __future__ import annotations

import os
import platform
import subprocess
import sys
import textwrap

import pytest

from tests.conftest import REPO

PROBE = textwrap.dedent(
    """
    import ctypes, sys
    import numpy as np

    class Mallinfo2(ctypes.Structure):
        _fields_ = [(name, ctypes.c_size_t) for name in
                    ("arena", "ordblks", "smblks", "hblks", "hblkhd", "usmblks", "fsmblks", "uordblks", "fordblks", "keepcost")]

    mallinfo2 = ctypes.CDLL(None).mallinfo2
    mallinfo2.restype = Mallinfo2

    def mapped_for(size):
        before = mallinfo2().hblkhd  # bytes in blocks malloc got from mmap
        block = np.ones(size, np.uint8)
        grown = mallinfo2().hblkhd - before
        del block
        return grown

    if sys.argv[1] == "keep":
        from clothtool.io.heap import keep_freed_memory
        keep_freed_memory()
    print(mapped_for(4 << 20))
    """
)


def mapped_bytes(mode: str) -> int:
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")])}
    out = subprocess.run([sys.executable, "-c", PROBE, mode], capture_output=True, text=True, check=True, env=env).stdout
    return int(out)


@pytest.mark.skipif(platform.libc_ver()[0] != "glibc", reason="the thresholds are glibc malloc's")
def test_a_frame_sized_block_comes_from_the_heap_once_freed_memory_is_kept():
    try:
        default = mapped_bytes("default")
    except subprocess.CalledProcessError as exc:
        if "mallinfo2" not in exc.stderr:
            raise
        pytest.skip("this glibc has no mallinfo2")
    assert default >= 4 << 20  # by default a 4 MiB block is a mapping of its own
    assert mapped_bytes("keep") == 0  # afterwards it comes from the heap
