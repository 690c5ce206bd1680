"""bake_many(): run a list of jobs on any ``concurrent.futures``-style executor.

Without an executor the jobs run one after another in this process; with a process pool
(``workers.local_executor``) or a Dask client's executor (``dask_cluster``) they run where
the executor sends them. Cooks run before bakes (a bake may read a fabric the batch
cooks). A failed job is recorded and the others go on. With a manifest path, jobs whose
output is up to date with the manifest are skipped (resume), and the manifest is
rewritten after every job.
"""

from __future__ import annotations

import concurrent.futures
import dataclasses
import glob
import os
from pathlib import Path
from typing import Callable, Iterator

from clothtool.batch.execute import JobResult, one_line, run_job
from clothtool.batch.inputs import hash_inputs
from clothtool.batch.jobs import Job, check_distinct_outputs
from clothtool.batch.manifest import entry, job_id, read_manifest, up_to_date, write_manifest


@dataclasses.dataclass
class BatchResult:
    """Every job's manifest entry (in job order) and the ids skipped as up to date."""

    entries: list[dict]
    skipped: list[str]

    @property
    def failed(self) -> list[dict]:
        return [e for e in self.entries if e["status"] != "ok"]

    @property
    def ok(self) -> bool:
        return not self.failed


def bake_many(
    jobs: list[Job],
    executor: concurrent.futures.Executor | None = None,
    manifest: str | os.PathLike | None = None,
    resume: bool = True,
    on_result: Callable[[dict, bool], None] | None = None,
) -> BatchResult:
    """Run ``jobs``; return their entries. ``on_result(entry, skipped)`` is called as each
    job finishes (or is found up to date). Output directories are created as needed.

    Paths in the entries are relative to the manifest's directory (or the current one).
    """
    check_distinct_outputs(jobs)
    manifest = Path(manifest) if manifest is not None else None
    root = manifest.parent if manifest is not None else Path.cwd()
    previous = read_manifest(manifest) if manifest is not None and resume else {}
    ids = [job_id(job, root) for job in jobs]
    entries = {i: previous[i] for i in ids if i in previous}  # kept until redone, so a kill loses nothing
    skipped: list[str] = []

    def record(job: Job, new: dict, was_skipped: bool) -> None:
        entries[new["id"]] = new
        if was_skipped:
            skipped.append(new["id"])
        if manifest is not None:
            write_manifest(manifest, list(entries.values()))
        if on_result is not None:
            on_result(new, was_skipped)

    for kind in ("cook", "bake"):
        todo = []
        for job in (j for j in jobs if j.kind == kind):
            inputs = hash_inputs(job)
            old = previous.get(job_id(job, root))
            if up_to_date(job, inputs, old, root):
                record(job, old, True)
            else:
                todo.append((job, inputs))
        created = [p for p in {Path(job.output).parent for job, _ in todo} if not p.exists()]
        for folder in created:
            folder.mkdir(parents=True, exist_ok=True)
        results = _run(todo, executor)
        for (job, inputs), result in results:
            record(job, entry(job, inputs, result, root), False)
        for job, _ in todo:
            remove_stale_temporaries(Path(job.output))
        for folder in created:  # no empty directories left behind by jobs that all failed
            if folder.is_dir() and not any(folder.iterdir()):
                folder.rmdir()
    return BatchResult([entries[i] for i in ids], skipped)


def _run(todo: list[tuple[Job, dict]], executor) -> Iterator[tuple[tuple[Job, dict], JobResult]]:
    if executor is None:
        for item in todo:
            yield item, run_job(item[0])
        return
    futures = {executor.submit(run_job, job): (job, inputs) for job, inputs in todo}
    try:
        for future in concurrent.futures.as_completed(futures):
            item = futures[future]
            try:
                result = future.result()
            except Exception as exc:  # the worker died or the executor broke: this job failed
                result = JobResult(item[0].output, "failed", f"worker lost: {one_line(exc)}")
            yield item, result
    finally:
        for future in futures:
            future.cancel()


def remove_stale_temporaries(output: Path) -> None:
    """Delete temporaries of ``output`` left by killed workers (``.NAME.tmp-PID...``).

    Called once the output's job has finished, so no live writer of ours owns them.
    """
    if not output.parent.is_dir():
        return
    for stale in output.parent.glob(f".{glob.escape(output.name)}.tmp-*"):
        try:
            stale.unlink()
        except OSError:
            pass
