"""Dask distributed as an executor for ``bake_many`` (the optional ``clothtool[dask]`` extra).

``dask_executor("tcp://HOST:8786")`` sends jobs to an existing cluster; ``"local"`` starts a
LocalCluster of single-threaded worker processes on this machine. Workers write outputs
through the library's temporary-file-then-rename path, so a worker lost mid-job leaves no
output under the final name; the scheduler reruns its job on another worker. Paths in the
jobs are absolute, so workers on other machines need the same shared file system paths.
"""

from __future__ import annotations

import contextlib

from clothtool.batch.jobs import Job
from clothtool.errors import ClothtoolError

NANNY_PRELOAD = "clothtool.batch.dask_nanny"
# A job's memory: the interpreter with numpy, numba, h5py and pxr loaded, plus the fabric
# and scene data expanded into solver arrays and buffered frames (a rough multiple of
# the input files' size; fabrics are stored compressed).
BASE_JOB_BYTES = 768 << 20
BYTES_PER_INPUT_BYTE = 16
INSTALL_HINT = 'install the extra with: python -m pip install "clothtool[dask]"'


def estimate_memory(job: Job) -> int:
    """A generous estimate of one job's peak memory in bytes (sizes the workers' limits)."""
    from clothtool.batch.inputs import job_inputs

    size = sum(path.stat().st_size for path in job_inputs(job))
    return BASE_JOB_BYTES + BYTES_PER_INPUT_BYTE * size


def _import_distributed():
    try:
        import distributed
    except ImportError:
        raise ClothtoolError(f"--scheduler needs Dask distributed, which is not installed; {INSTALL_HINT}") from None
    return distributed


@contextlib.contextmanager
def dask_executor(scheduler: str, jobs: list[Job], workers: int = 2, connect_timeout: float = 30.0):
    """A ``concurrent.futures`` executor on a Dask cluster: ``scheduler`` is an address
    (``tcp://HOST:PORT``) or ``"local"`` for a LocalCluster of ``workers`` processes whose
    memory limit is the largest job's estimate."""
    distributed = _import_distributed()
    stack = contextlib.ExitStack()
    with stack:
        if scheduler == "local":
            memory = max((estimate_memory(job) for job in jobs), default=BASE_JOB_BYTES)
            cluster = stack.enter_context(distributed.LocalCluster(
                n_workers=workers, threads_per_worker=1, processes=True, memory_limit=memory,
                preload_nanny=[NANNY_PRELOAD], dashboard_address=None, host="127.0.0.1",
            ))
            address = cluster
        else:
            if "://" not in scheduler:
                raise ClothtoolError(f"--scheduler {scheduler}: give tcp://HOST:PORT of a Dask scheduler, or 'local'")
            address = scheduler
        try:
            client = stack.enter_context(distributed.Client(address, timeout=connect_timeout))
        except OSError as exc:
            raise ClothtoolError(
                f"--scheduler {scheduler}: cannot reach the Dask scheduler ({exc}); check the address and that it runs"
            ) from None
        yield client.get_executor(pure=False)
