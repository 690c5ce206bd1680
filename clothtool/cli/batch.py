"""Batch plumbing shared by ``cook``, ``bake`` and ``batch``: options, executors, progress,
the end-of-batch summary. ``clothtool batch JOBS.toml`` runs a batch file."""

from __future__ import annotations

import contextlib
import sys
import time
from pathlib import Path

import click

from clothtool.cli.common import emit_json, handle_errors, stderr_is_terminal
from clothtool.errors import ClothtoolError, UsageError


def batch_options(func):
    """--jobs, --scheduler, --manifest, --resume."""
    options = [
        click.option("--jobs", "-j", "jobs_n", type=click.IntRange(min=1), default=1, show_default=True,
                     help="Run jobs in N worker processes (one numba and one BLAS thread each); with --scheduler local, N Dask workers."),
        click.option("--scheduler", metavar="tcp://HOST:PORT|local",
                     help="Run jobs on a Dask cluster, or on a LocalCluster started here (needs clothtool[dask])."),
        click.option("--manifest", type=click.Path(dir_okay=False, path_type=Path),
                     help="Batch manifest to write and resume from [the output template's top directory/manifest.json]."),
        click.option("--resume/--no-resume", default=True,
                     help="Skip jobs whose outputs match the manifest's input hashes and settings [on]."),
    ]
    for option in reversed(options):
        func = option(func)
    return func


progress_option = click.option("--progress/--no-progress", default=None,
                               help="Progress over jobs on stderr: a bar on a terminal, plain lines in a log [on].")


def wedge_options(func):
    func = click.option("--wedge-zip", "wedge_zips", multiple=True, metavar="KEY=V1,V2,...",
                        help="Wedge keys in step: every --wedge-zip list has the same length (repeatable).")(func)
    return click.option("--wedge", "wedges", multiple=True, metavar="KEY=V1,V2,...",
                        help="Bake one cache per value; several --wedge make the Cartesian product (batch mode).")(func)


def is_batch(inputs, output, **given) -> bool:
    """Batch mode: several inputs, a glob, an output template, or any batch option."""
    if len(inputs) > 1 or any(glob_magic(str(i)) for i in inputs) or (output is not None and "{" in str(output)):
        return True
    return bool(given.get("scheduler") or given.get("manifest") or given.get("wedges") or given.get("wedge_zips")
                or given.get("jobs_n", 1) > 1)


def glob_magic(text: str) -> bool:
    import glob

    return glob.has_magic(text)


def default_manifest(template: str) -> Path:
    """``manifest.json`` in the template's fixed top directory (caches/{scene}/x.usdc -> caches/)."""
    prefix = template.split("{", 1)[0]
    folder = Path(prefix) if prefix.endswith(("/", "\\")) else Path(prefix).parent
    return folder / "manifest.json"


@contextlib.contextmanager
def _executor(jobs, jobs_n: int, scheduler: str | None):
    if scheduler:
        from clothtool.batch.dask_cluster import dask_executor

        with dask_executor(scheduler, jobs, workers=max(jobs_n, 1)) as executor:
            yield executor
    elif jobs_n > 1:
        from clothtool.batch.workers import local_executor

        with local_executor(jobs_n) as executor:
            yield executor
    else:
        yield None


@contextlib.contextmanager
def _progress(total: int, enabled: bool):
    """Yield on_result(entry, skipped): a rich bar on a terminal, else one plain line per job."""
    done = [0]

    def line(entry, skipped):
        done[0] += 1
        state = "up to date" if skipped else entry["status"]
        extra = f": {entry['error']}" if entry["status"] != "ok" else f" ({entry['timing']['wall_s']:.1f} s)"
        click.echo(f"[{done[0]}/{total}] {state} {entry['id']}{'' if skipped else extra}", err=True)

    if not enabled:
        yield None
        return
    if not stderr_is_terminal():
        yield line
        return
    from rich.console import Console
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TimeRemainingColumn

    with Progress("[progress.description]{task.description}", BarColumn(), MofNCompleteColumn(), TimeRemainingColumn(),
                  console=Console(file=sys.stderr), transient=True) as progress:
        task = progress.add_task("jobs", total=total)

        def advance(entry, skipped):
            if entry["status"] != "ok":
                progress.console.print(f"failed {entry['id']}: {entry['error']}", markup=False, highlight=False)
            progress.advance(task)

        yield advance


def run_batch(jobs, manifest: Path, jobs_n: int, scheduler: str | None, resume: bool, progress: bool | None,
              as_json: bool) -> None:
    """Run ``jobs``, print the summary (or the manifest as JSON); exit code 1 if any failed."""
    from clothtool.batch.manifest import dumps
    from clothtool.batch.runner import bake_many
    from clothtool.batch.table import format_batch_summary

    if not jobs:
        raise UsageError("no jobs to run; give input files")
    manifest.parent.mkdir(parents=True, exist_ok=True)
    start = time.perf_counter()
    with _executor(jobs, jobs_n, scheduler) as executor, _progress(len(jobs), progress is not False) as on_result:
        result = bake_many(jobs, executor=executor, manifest=manifest, resume=resume, on_result=on_result)
    if as_json:
        import json

        emit_json(json.loads(dumps(result.entries)))
    else:
        click.echo(format_batch_summary(result.entries, result.skipped, str(manifest), time.perf_counter() - start))
    if result.failed:
        raise ClothtoolError(f"{len(result.failed)} of {len(result.entries)} jobs failed (see the list above and {manifest})")


def template_jobs(kind: str, inputs, output: str | None, **job_settings):
    """Jobs from command-line inputs (paths and globs) and an output template."""
    from clothtool.batch.jobs import expand_inputs, make_jobs

    if output is None:
        raise UsageError("Missing option '-o' / '--output': give an output template such as 'out/{name}.usdc'")
    return make_jobs(kind, expand_inputs([str(i) for i in inputs]), str(output), **job_settings)


def run_cook_batch(meshes, output, preset, prim, strict, options: dict, as_json, jobs_n, scheduler, manifest, resume,
                   progress) -> None:
    if prim:
        options = {**options, "prim": prim}
    jobs = template_jobs("cook", meshes, output, cook_options=options, preset=preset, strict=strict)
    run_batch(jobs, manifest or default_manifest(str(output)), jobs_n, scheduler, resume, progress, as_json)


# bake options that describe one bake's side outputs, not a batch's jobs
SINGLE_BAKE_ONLY = {"dry_run": "--dry-run", "report_path": "--report", "profile": "--profile",
                    "compression": "--compression", "save_every": "--save-every"}


def run_bake_batch(scenes, output, overrides, frames, strict, wedges, wedge_zips, as_json, jobs_n, scheduler, manifest,
                   resume, progress, **single) -> None:
    from clothtool.batch.jobs import expand_wedges

    given = [SINGLE_BAKE_ONLY[k] for k, v in single.items() if v]
    if given:
        raise UsageError(f"{given[0]} applies to a single bake; a batch records each job's stats in its manifest "
                         "(use --set output.compression=... for cache settings)")
    jobs = template_jobs("bake", scenes, output, wedges=expand_wedges(list(wedges), list(wedge_zips)),
                         overrides=tuple(overrides), frames=frames, strict=strict)
    run_batch(jobs, manifest or default_manifest(str(output)), jobs_n, scheduler, resume, progress, as_json)


@click.command()
@click.argument("batch_file", type=click.Path(dir_okay=False, path_type=Path))
@batch_options
@progress_option
@click.option("--json", "as_json", is_flag=True, help="Print the manifest as JSON on stdout.")
@handle_errors
def batch(batch_file: Path, jobs_n, scheduler, manifest, resume, progress, as_json) -> None:
    """Run the cook and bake jobs listed in BATCH_FILE (TOML; see the README's "Many bakes").

    One failing job does not stop the others; exit code 1 when any failed. A re-run skips
    jobs whose outputs are up to date with the manifest.

    \b
    Examples:
      clothtool batch ci/assets.toml --jobs 2
      clothtool batch ci/assets.toml --scheduler tcp://farm:8786
    """
    from clothtool.batch.batchfile import load_batch_file

    jobs, listed = load_batch_file(batch_file)
    run_batch(jobs, manifest or listed, jobs_n, scheduler, resume, progress, as_json)
