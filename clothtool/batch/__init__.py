"""Many cooks and bakes: batches of jobs, wedges, a manifest with resume, and executors.

    from clothtool.batch import bake_many, make_jobs, expand_wedges
    jobs = make_jobs("bake", [Path("shot.toml")], "caches/{scene}/{wedge}.usdc",
                     wedges=expand_wedges(["solver.frequency=300,600"]))
    result = bake_many(jobs, executor=local_executor(2), manifest="caches/manifest.json")

Any ``concurrent.futures``-style executor works: a process pool (``local_executor``) or a
Dask client's (``clothtool.batch.dask_cluster``).
"""

from clothtool.batch.execute import JobResult, run_job
from clothtool.batch.jobs import Job, expand_inputs, expand_wedges, make_jobs
from clothtool.batch.runner import BatchResult, bake_many
from clothtool.batch.workers import local_executor

__all__ = [
    "BatchResult", "Job", "JobResult", "bake_many", "expand_inputs", "expand_wedges", "local_executor", "make_jobs", "run_job",
]
