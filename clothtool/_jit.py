"""The one place that configures numba.

Kernels are compiled with ``cache=True`` (compiled code is stored beside the sources, so a
second run pays no compile time). Of fastmath's flags only ``contract`` is on: it fuses
multiply-adds (about 20% off the fabric kernel, whose cost is its dependency chain) and, unlike
the others, keeps NaN/inf semantics (the instability checks rely on them) and the bit-identity
of a kernel's serial and parallel versions (tested). numba is imported lazily by the
modules that hold kernels, never by ``import clothtool``.
"""

from __future__ import annotations

import os
import types

# Idle OpenMP threads spin by default. On a machine shared with other jobs (a render node,
# --jobs N bakes, CI) the spinning threads of one process starve the others and a parallel
# kernel call can stall for milliseconds; passive waiting costs ~10% on an idle machine.
# Must be set before numba first starts its thread pool; a user's own setting wins.
os.environ.setdefault("OMP_WAIT_POLICY", "passive")

import numba  # noqa: E402  (after the environment above)

KERNEL_OPTIONS = dict(cache=True, nogil=True, fastmath={"contract"}, error_model="numpy", boundscheck=False)


def kernel(func=None, **overrides):
    """``numba.njit`` with the project's options; usable as ``@kernel`` or ``@kernel(parallel=True)``."""
    options = {**KERNEL_OPTIONS, **overrides}
    if func is None:
        return lambda f: numba.njit(**options)(f)
    return numba.njit(**options)(func)


def serial_and_parallel(func):
    """Two compilations of one kernel source: serial, and parallel (``numba.prange`` loops run
    on all cores). Each gets its own function name, so their numba cache entries stay apart;
    kernels written for this only prange over conflict-free work, so both give the same bits."""

    def named(suffix: str):
        copy = types.FunctionType(func.__code__, func.__globals__, func.__name__ + suffix, func.__defaults__)
        copy.__qualname__ = func.__qualname__ + suffix
        return copy

    return kernel(named("_serial")), kernel(parallel=True)(named("_parallel"))
