"""The one place that configures numba.

Kernels are compiled with ``cache=True`` (compiled code is stored beside the sources, so a
second run pays no compile time) and without fastmath, so that NaN checks work and a
kernel's serial and parallel versions give the same bits. numba is imported lazily by the
modules that hold kernels, never by ``import clothtool``.
"""

from __future__ import annotations

import numba

KERNEL_OPTIONS = dict(cache=True, nogil=True, fastmath=False, error_model="numpy", boundscheck=False)


def kernel(func=None, **overrides):
    """``numba.njit`` with the project's options; usable as ``@kernel`` or ``@kernel(parallel=True)``."""
    options = {**KERNEL_OPTIONS, **overrides}
    if func is None:
        return lambda f: numba.njit(**options)(f)
    return numba.njit(**options)(func)
