"""Local worker processes: one thread each, so N jobs share N cores without oversubscribing.

numba reads NUMBA_NUM_THREADS and OpenBLAS/MKL/OpenMP read theirs when first imported, so
the limits go into the environment of a freshly spawned process before any job (and with
it numpy or numba) is unpickled there. This module imports neither.
"""

from __future__ import annotations

import multiprocessing
import os
import sys
from concurrent.futures import ProcessPoolExecutor

SINGLE_THREAD_ENV = {
    "NUMBA_NUM_THREADS": "1",
    "OMP_NUM_THREADS": "1",
    "OPENBLAS_NUM_THREADS": "1",
    "MKL_NUM_THREADS": "1",
}


def limit_threads() -> None:
    """Run this process's jobs on one thread (a process-pool initializer)."""
    os.environ.update(SINGLE_THREAD_ENV)
    if "numba" in sys.modules:  # already imported (e.g. a Dask worker): lower its thread count
        import numba

        numba.set_num_threads(1)


def local_executor(jobs: int) -> ProcessPoolExecutor:
    """``jobs`` spawned worker processes with one numba and one BLAS thread each.

    Spawned, not forked: a fork would inherit numba's thread pool and the parent's
    imports, and with them the parent's thread counts.
    """
    return ProcessPoolExecutor(max_workers=jobs, mp_context=multiprocessing.get_context("spawn"), initializer=limit_threads)
