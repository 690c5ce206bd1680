"""Keep the memory a cache writer frees for its next frames instead of returning it.

Writers allocate and free the same large blocks every frame (a frame's arrays, USD's
samples dropped at each save, HDF5 chunks) and glibc's malloc, by default, hands freed
memory at the top of its heap back to the system once more than ~2x its largest recent
mmap'd block is free (M_TRIM_THRESHOLD), and serves blocks above its mmap threshold with
fresh mappings. Either way the next frame faults the same pages in again, zero-filled by
the kernel: ~0.35 ms a frame of a 128^2 USD bake, half of its writer's CPU time.

glibc adapts both thresholds by itself: freeing an mmap'd block of S bytes raises the
mmap threshold to S and the trim threshold to 2S (mallopt(3), "dynamic mmap threshold").
``keep_freed_memory`` lets it adapt once, early: it allocates and frees one block of
``_BLOCK`` bytes, never touched (so it costs one mmap and one munmap, no memory). After it
blocks under 16 MiB come from the heap and up to 32 MiB of freed memory stays with the
process. Other allocators ignore the hint.
"""

from __future__ import annotations

import functools

import numpy as np

# The largest block whose free still raises the thresholds (glibc caps the dynamic mmap
# threshold at 32 MiB on 64-bit systems, and a block's size includes its header).
_BLOCK = 16 << 20


@functools.cache
def keep_freed_memory() -> None:
    """Once per process: let malloc keep freed memory for reuse (see the module docstring)."""
    block = np.empty(_BLOCK, np.uint8)
    del block
