"""run_job(): run one job where it lands (this process, a worker process, a Dask worker).

It calls the same library entry points as ``clothtool cook`` and ``clothtool bake``, writes
the output through their atomic temporary-file path, and never raises for a failed job:
the result carries a one-line error instead, so one bad job cannot stop a batch.
"""

from __future__ import annotations

import dataclasses
import time
from pathlib import Path

from clothtool.batch.inputs import file_sha256
from clothtool.batch.jobs import Job, format_value
from clothtool.errors import ClothtoolError


@dataclasses.dataclass
class JobResult:
    """What running a job did.

    Attributes:
        output: the job's output path (as in the job).
        status: "ok" or "failed".
        error: one line saying why it failed (None when ok).
        output_sha256: hash of the written output (None when failed).
        wall_s, cpu_s: time the job took in its worker.
        stats: headline figures (bake: max strain, max speed, finite; cook: sizes, warnings).
        resolved: the settings in force after presets and overrides (bake: the solver).
    """

    output: str
    status: str
    error: str | None = None
    output_sha256: str | None = None
    wall_s: float = 0.0
    cpu_s: float = 0.0
    stats: dict = dataclasses.field(default_factory=dict)
    resolved: dict = dataclasses.field(default_factory=dict)


def one_line(exc: BaseException) -> str:
    text = str(exc).strip()
    first = text.splitlines()[0] if text else ""
    if isinstance(exc, ClothtoolError):
        return first or type(exc).__name__
    return f"internal error ({type(exc).__name__}: {first})"


def run_job(job: Job) -> JobResult:
    """Run ``job``; every failure (bad input, unstable bake, a bug) becomes a failed result."""
    wall0, cpu0 = time.perf_counter(), time.process_time()
    stats: dict = {}
    resolved: dict = {}
    try:
        if job.kind == "cook":
            stats, resolved = _cook(job)
        elif job.kind == "bake":
            stats, resolved = _bake(job, stats)
        else:
            raise ClothtoolError(f"{job.input}: job kind '{job.kind}' is not cook or bake")
        digest = file_sha256(job.output)
    except Exception as exc:  # a failed job is a result, not a crash of the batch
        return JobResult(job.output, "failed", one_line(exc), None, time.perf_counter() - wall0,
                         time.process_time() - cpu0, stats, resolved)
    return JobResult(job.output, "ok", None, digest, time.perf_counter() - wall0, time.process_time() - cpu0, stats, resolved)


def _cook(job: Job) -> tuple[dict, dict]:
    from clothtool.cook.cooker import CookOptions, cook_fabric
    from clothtool.inputs import recording_inputs, refuse_output_onto_input
    from clothtool.io.atomic import check_output_path
    from clothtool.io.fabric_file import check_fabric_output_name, write_fabric
    from clothtool.io.meshin import read_mesh
    from clothtool.presets import apply_mapping, load_preset
    from clothtool.summary import fabric_summary

    check_fabric_output_name(job.output)
    check_output_path(job.output)
    with recording_inputs() as inputs:
        options = CookOptions()
        if job.preset:
            mapping, label = load_preset("cook", job.preset)
            options = apply_mapping(options, mapping, label, skip=("strict",))
        given = dict(job.cook_options)
        prim = given.pop("prim", None)
        options = apply_mapping(options, given, f"{job.input}: cook options", skip=("strict",))
        options = dataclasses.replace(options, strict=job.strict)
        path = Path(job.input)
        mesh = read_mesh(path, prim=prim)
        result = cook_fabric(mesh, options, source_sha256=file_sha256(path))
    refuse_output_onto_input(job.output, inputs)
    write_fabric(result.fabric, job.output)
    summary = fabric_summary(result.fabric)
    stats = {
        "particles": summary["particles"],
        "phases": len(summary["phases"]),
        "welded_vertices": result.welded_vertices,
        "warnings": list(result.warnings),
        "valid": summary["validation"] == "ok",
    }
    return stats, {"cook": _json_safe(dataclasses.asdict(options))}


def wedge_metadata(job: Job) -> tuple[tuple[str, str], ...]:
    """Cache metadata recording the wedge: ``wedge`` (its label) and ``wedge:KEY`` = value."""
    if not job.wedge:
        return ()
    return (("wedge", job.wedge_label),) + tuple((f"wedge:{key}", format_value(value)) for key, value in job.wedge)


def _bake(job: Job, stats: dict) -> tuple[dict, dict]:
    from clothtool.bake import BakeOptions, bake
    from clothtool.errors import UnstableError
    from clothtool.io.cache import NULL_OUTPUTS
    from clothtool.preflight import load_for_bake

    if job.output in NULL_OUTPUTS:  # a batch is for files that resume can check
        raise ClothtoolError(f"{job.output}: a batch bake writes a cache file; name it .usdc, .usda, .usd or .h5")
    scene = load_for_bake(job.input, job.output, list(job.overrides) + job.wedge_overrides, job.frames, job.strict)
    try:
        report = bake(scene, job.output, BakeOptions(penetration=True, metadata=wedge_metadata(job))).to_dict()
    except UnstableError as exc:
        if getattr(exc, "stats", None) is not None:  # keep the headline figures of the failed bake
            stats.update(headline_stats(exc.stats.to_dict()))
        raise
    resolved = {"solver": _json_safe(report["solver"]), "frames": [report["frames"]["start"], report["frames"]["end"]],
                "fps": report["frames"]["fps"]}
    return headline_stats(report), resolved


def headline_stats(report: dict) -> dict:
    """Max strain, max speed, max penetration (when the solver measures it), NaN check."""
    overall = report.get("overall", {})
    strains = [s["max"] for cloth in overall.values() for s in cloth["strain"].values()]
    stats = {
        "frames_simulated": report["frames"]["simulated"],
        "max_strain": max(strains) if strains else 0.0,
        "max_speed": max((c["max_speed"] for c in overall.values()), default=0.0),
        "finite": all(c["finite"] for c in overall.values()),
        "particles": sum(c["particles"] for c in report.get("cloths", {}).values()),
    }
    penetrations = [c["max_penetration"] for c in overall.values() if "max_penetration" in c]
    if penetrations:
        stats["max_penetration"] = max(penetrations)
    return stats


def _json_safe(value):
    """Tuples to lists and numpy scalars to Python numbers, so the manifest is plain JSON."""
    if isinstance(value, dict):
        return {str(k): _json_safe(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_json_safe(v) for v in value]
    if hasattr(value, "item") and not isinstance(value, (str, bytes)):
        return value.item()
    return value
