"""Dask nanny preload: the environment clothtool's jobs want in the worker processes.

Start workers with it (``dask worker tcp://HOST:8786 --nthreads 1 --preload-nanny
clothtool.batch.dask_nanny``); ``--scheduler local`` uses it for its LocalCluster.

Dask's nanny sets ``MALLOC_TRIM_THRESHOLD_=65536`` in every worker it spawns, which makes
glibc hand freed memory back to the system almost at once; numpy-heavy bakes then pay for
page faults on every new array and run several times slower. glibc reads it when the
process starts, so it must be dropped in the nanny, before the worker is spawned. The
thread limits give each single-threaded Dask worker one numba and one BLAS thread.
"""

from __future__ import annotations

from clothtool.batch.workers import SINGLE_THREAD_ENV

DROPPED = ("MALLOC_TRIM_THRESHOLD_",)


def dask_setup(nanny) -> None:
    for name in DROPPED:
        nanny.pre_spawn_env.pop(name, None)
        nanny.env.pop(name, None)
    nanny.env.update(SINGLE_THREAD_ENV)
