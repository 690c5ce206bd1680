"""The batch manifest: one JSON file recording every job of a batch, and what resume reads.

Per job: its inputs with content hashes, the settings it asked for and the ones in force,
its output with a hash, status, one-line error, CPU and wall time, headline stats. Paths
are relative to the manifest's directory (no absolute paths, hosts or timestamps); jobs
are sorted by output and keys sorted, so the same batch gives the same file apart from
the time figures. It is rewritten atomically after every finished job, so a batch killed
mid-way leaves a manifest of the jobs it finished.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

from clothtool import __version__
from clothtool.batch.execute import JobResult
from clothtool.batch.inputs import file_sha256
from clothtool.batch.jobs import Job
from clothtool.errors import ClothtoolError

FORMAT = "clothtool-batch-manifest"
VERSION = 1


def relative(path: str | Path, root: Path) -> str:
    """``path`` relative to ``root`` in POSIX form (stable across machines)."""
    return Path(os.path.relpath(Path(path).resolve(), root.resolve())).as_posix()


def job_id(job: Job, root: Path) -> str:
    return relative(job.output, root)


def entry(job: Job, inputs: dict[Path, str], result: JobResult, root: Path) -> dict:
    """The manifest record of one finished job."""
    return {
        "id": job_id(job, root),
        "kind": job.kind,
        "input": relative(job.input, root),
        "inputs": {relative(path, root): digest for path, digest in inputs.items()},
        "settings": job.settings(),
        "resolved": result.resolved,
        "outputs": {relative(job.output, root): result.output_sha256} if result.output_sha256 else {},
        "status": result.status,
        "error": relative_error(result.error, job, root),
        "stats": result.stats,
        "timing": {"wall_s": round(result.wall_s, 3), "cpu_s": round(result.cpu_s, 3)},
    }


def relative_error(error: str | None, job: Job, root: Path) -> str | None:
    """The error line with the job's file and directory paths made relative to ``root``
    (library errors name files as given, and batch jobs carry absolute paths)."""
    if error is None:
        return None
    paths = {Path(job.input), Path(job.output), Path(job.input).parent, Path(job.output).parent}
    paths |= {p.resolve() for p in paths}
    for path in sorted(paths, key=lambda p: len(str(p)), reverse=True):
        if path.is_absolute() and len(path.parts) > 1:
            error = error.replace(str(path), relative(path, root))
    return error


def summary(entries: list[dict]) -> dict:
    return {
        "jobs": len(entries),
        "ok": sum(e["status"] == "ok" for e in entries),
        "failed": sum(e["status"] == "failed" for e in entries),
        "wall_s": round(sum(e["timing"]["wall_s"] for e in entries), 3),
        "cpu_s": round(sum(e["timing"]["cpu_s"] for e in entries), 3),
    }


def dumps(entries: list[dict]) -> str:
    ordered = sorted(entries, key=lambda e: e["id"])
    document = {"format": FORMAT, "version": VERSION, "clothtool": __version__, "summary": summary(ordered), "jobs": ordered}
    return json.dumps(document, indent=2, sort_keys=True) + "\n"


def write_manifest(path: Path, entries: list[dict]) -> None:
    """Write atomically (temporary file, then rename): a kill never leaves half a manifest."""
    from clothtool.io.atomic import atomic_output

    with atomic_output(path) as tmp:
        Path(tmp).write_text(dumps(entries))


def read_manifest(path: Path) -> dict[str, dict]:
    """The previous run's entries by job id; {} when there is no manifest yet."""
    path = Path(path)
    if not path.exists():
        return {}
    return {e["id"]: e for e in load_manifest_document(path)["jobs"] if isinstance(e, dict) and "id" in e}


def load_manifest_document(path: Path) -> dict:
    """The whole manifest, checked to be one."""
    path = Path(path)
    if not path.is_file():
        raise ClothtoolError(f"{path}: manifest not found; check the path")
    try:
        document = json.loads(path.read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise ClothtoolError(f"{path}: not a readable batch manifest ({exc}); delete it to start the batch afresh") from None
    if not isinstance(document, dict) or document.get("format") != FORMAT or not isinstance(document.get("jobs"), list):
        raise ClothtoolError(f"{path}: not a clothtool batch manifest; give another --manifest path or delete the file")
    if document.get("version") != VERSION:
        raise ClothtoolError(f"{path}: manifest version {document.get('version')!r} is not {VERSION}; delete it to start afresh")
    return document


def up_to_date(job: Job, inputs: dict[Path, str], previous: dict | None, root: Path) -> bool:
    """True when ``previous`` (this job's old entry) finished ok with the same kind, input
    hashes and settings, and its output still exists with the recorded hash."""
    if not previous or previous.get("status") != "ok" or previous.get("kind") != job.kind:
        return False
    if previous.get("settings") != json.loads(json.dumps(job.settings())):
        return False
    if previous.get("inputs") != {relative(path, root): digest for path, digest in inputs.items()}:
        return False
    output = Path(job.output)
    recorded = previous.get("outputs", {}).get(relative(output, root))
    return recorded is not None and output.is_file() and file_sha256(output) == recorded
