"""clothtool study: speed against error over swept settings, against a converged reference.

For each setting (a combination of swept values) the scene is baked ``repeats`` times (the
median wall time counts) into memory, and compared with a reference bake: by default the
same scene, unswept, at a much higher solver frequency, checked for convergence by doubling
its frequency until the change is below 10% of the smallest error the study reports (or the
doubling budget runs out, which the result says).

Every bake runs in the precision the user asked for: each setting in its own (the scene's,
``--set``'s or the sweep's), the reference in the scene's, or float64 when a sweep asks for
float64 (``--reference solver.precision=...`` decides otherwise). Each row records its
precision and its round-off floor (clothtool.study.roundoff), so an error that stops falling
because of round-off is marked as such instead of passing for convergence. With a target
error, each family's time to reach it is reported (clothtool.study.target).
"""

from __future__ import annotations

import dataclasses
import math
import statistics
from pathlib import Path

import numpy as np

from clothtool.bake import BakeOptions, bake
from clothtool.errors import ClothtoolError, UnstableError
from clothtool.io.memory import MemoryCacheWriter
from clothtool.loading import load_scene
from clothtool.scene.scene import Scene
from clothtool.study import roundoff
from clothtool.study.machine import machine_info
from clothtool.study.sweep import Setting, Sweep, settings
from clothtool.study.target import time_to_error

METRICS = ("position", "strain", "penetration", "energy")
# metric -> the row's column that measures it
METRIC_KEYS = {"position": "position_rms", "strain": "strain_max", "penetration": "penetration_max",
               "energy": "energy_drift_J"}
PRECISION_KEY = "solver.precision"
# Frames compared against the reference: about this many, evenly spaced, plus the last.
COMPARED_FRAMES = 24


@dataclasses.dataclass(frozen=True)
class StudyOptions:
    sweeps: tuple[Sweep, ...]
    metric: str = "position"
    repeats: int = 3
    overrides: tuple[str, ...] = ()
    reference: tuple[str, ...] = ()  # extra overrides for the reference bake
    reference_frequency: float | None = None  # default: 8x the largest swept/scene frequency
    reference_doublings: int = 2  # how often the reference may double its frequency
    frames: tuple[int, int] | None = None
    target_error: float | None = None  # report each family's time to reach this error


@dataclasses.dataclass(frozen=True)
class Previous:
    """An earlier study in the output directory (``--append``): its rows and reference."""

    rows: list[dict]
    reference_frames: dict[int, tuple[np.ndarray, ...]]
    reference: dict
    scene: str
    where: str


@dataclasses.dataclass
class Bake:
    """Positions of the compared frames plus what the bake reported."""

    frames: dict[int, tuple[np.ndarray, ...]]
    report: dict
    wall_s: float
    masses: tuple[np.ndarray, ...]


@dataclasses.dataclass
class StudyResult:
    scene: str
    metric: str
    rows: list[dict]
    reference: dict
    machine: dict
    sweeps: list[dict]
    reference_frames: dict[int, tuple[np.ndarray, ...]] = dataclasses.field(default_factory=dict)
    target: dict | None = None  # {"error", "metric", "families": time_to_error(...)} with --target-error


def _keep_every(scene: Scene) -> int:
    return max(1, (scene.frame_count - 1) // COMPARED_FRAMES)


def _bake_once(scene: Scene) -> Bake:
    writer = MemoryCacheWriter(keep_every=_keep_every(scene))
    stats = bake(scene, writer, BakeOptions(percentiles=True, penetration=True))
    masses = tuple(c.fabric.particle_area.astype(np.float64) * c.material.areal_density for c in scene.cloths)
    return Bake(writer.frames, stats.to_dict(), stats.simulation_s, masses)


def _load(path: Path, overrides: list[str], frames) -> Scene:
    return load_scene(path, overrides, frames)


def _scene_frequency(scene: Scene) -> float:
    return scene.solver.frequency


def position_errors(bake_frames, reference_frames, size: float) -> tuple[float, float]:
    """(RMS, max) distance to the reference over compared frames and particles, / size."""
    squares, worst, count = 0.0, 0.0, 0
    for frame, clouds in bake_frames.items():
        if frame not in reference_frames:
            continue
        for mine, theirs in zip(clouds, reference_frames[frame]):
            d = np.linalg.norm(mine - theirs, axis=1)
            squares += float(np.sum(d * d))
            worst = max(worst, float(d.max()))
            count += d.shape[0]
    if count == 0:
        return math.nan, math.nan
    return math.sqrt(squares / count) / size, worst / size


def _cloth_size(reference: Bake) -> float:
    first = reference.frames[min(reference.frames)]
    points = np.vstack(first)
    return float(np.linalg.norm(points.max(axis=0) - points.min(axis=0))) or 1.0


def _energy_drift(b: Bake, gravity: np.ndarray, meters_per_unit: float) -> float:
    """Change of kinetic plus gravitational energy (J) from the first to the last frame."""
    frames = sorted(b.frames)
    if len(frames) < 2:
        return 0.0
    g = np.asarray(gravity) * meters_per_unit

    def potential(frame):
        return -sum(float(np.sum(m * ((p * meters_per_unit) @ g))) for m, p in zip(b.masses, b.frames[frame]))

    last = b.report["per_frame"][-1]["cloths"] if b.report["per_frame"] else {}
    kinetic = sum(c["kinetic_energy"] for c in last.values())
    return kinetic + potential(frames[-1]) - potential(frames[0])


def _metric_values(b: Bake, scene: Scene) -> dict:
    """The row's metric columns that depend only on the bake itself (not on the reference)."""
    overall = b.report["overall"]
    return {
        "strain_max": max((s["max"] for c in overall.values() for s in c["strain"].values()), default=0.0),
        "penetration_max": max((c.get("max_penetration", 0.0) for c in overall.values()), default=0.0),
        "energy_drift_J": _energy_drift(b, scene.gravity, scene.meters_per_unit),
    }


def _roundoff(run: Bake, twin: Bake | None, precision: str, size: float, scene: Scene) -> tuple[dict, str]:
    """Round-off of each metric column: measured against the float64 twin of a float32 run,
    else estimated (position only)."""
    if precision == "float64" or twin is None:
        iterations = run.report["iterations_per_frame"] * run.report["frames"]["simulated"]
        if precision == "float32":  # its twin went unstable: nothing to measure against
            return {}, roundoff.UNMEASURED
        value = roundoff.estimate(precision, iterations, roundoff.extent(run.frames), size)
        return {"position_rms": value, "position_max": value}, roundoff.ESTIMATED
    rms, worst = position_errors(run.frames, twin.frames, size)
    mine, theirs = _metric_values(run, scene), _metric_values(twin, scene)
    values = {key: abs(mine[key] - theirs[key]) for key in mine}
    values.update(position_rms=rms, position_max=worst)
    return values, roundoff.MEASURED


def _row(setting: Setting, runs: list[Bake], reference: Bake, size: float, scene: Scene,
         precision: str, twin: Bake | None) -> dict:
    median = sorted(runs, key=lambda r: r.wall_s)[len(runs) // 2]
    report = median.report
    simulated_s = report["frames"]["simulated"] / report["frames"]["fps"] if report["frames"]["fps"] else 0.0
    overall = report["overall"]
    values = _metric_values(median, scene)
    strain_mean = float(np.mean([s["mean"] for c in overall.values() for s in c["strain"].values()] or [0.0]))
    strain_p99 = max((s.get("p99", 0.0) for c in overall.values() for s in c["strain"].values()), default=0.0)
    rms, worst = position_errors(median.frames, reference.frames, size)
    constraints = sum(c["constraints"] for c in report["cloths"].values())
    projections = constraints * report["iterations_per_frame"] * report["frames"]["simulated"]
    wall = statistics.median(r.wall_s for r in runs)
    rounding, source = _roundoff(median, twin, precision, size, scene)
    return {
        "setting": setting.as_dict(),
        "label": setting.label,
        "family": setting.family,
        "failed": None,
        "precision": precision,
        "roundoff": rounding,
        "roundoff_source": source,
        "wall_s": wall,
        "wall_s_per_simulated_s": wall / simulated_s if simulated_s else math.nan,
        "runs_s": [r.wall_s for r in runs],
        "constraint_projections_per_simulated_s": projections / simulated_s if simulated_s else math.nan,
        "strain_max": values["strain_max"],
        "strain_mean": strain_mean,
        "strain_p99": strain_p99,
        "position_rms": rms,
        "position_max": worst,
        "penetration_max": values["penetration_max"],
        "energy_drift_J": values["energy_drift_J"],
    }


def _failed_row(setting: Setting, message: str, precision: str) -> dict:
    row = {key: math.nan for key in ("wall_s", "wall_s_per_simulated_s", "constraint_projections_per_simulated_s",
                                     "strain_max", "strain_mean", "strain_p99", "position_rms", "position_max",
                                     "penetration_max", "energy_drift_J")}
    row.update(setting=setting.as_dict(), label=setting.label, family=setting.family, failed=message, runs_s=[],
               precision=precision, roundoff={}, roundoff_source=None)
    return row


def _mark_floor(rows: list[dict], key: str, reference_roundoff: float) -> None:
    """Each row's floor for the study's metric and whether its error is at it."""
    for row in rows:
        if row.get("failed"):
            row.update(floor=math.nan, at_floor=False)
            continue
        row.setdefault("roundoff", {})
        floor = roundoff.floor_of(row, key, reference_roundoff)
        row.update(floor=floor, at_floor=roundoff.at_floor(row[key], floor))


def _reference_overrides(options: StudyOptions, all_settings: list[Setting]) -> list[str]:
    """The reference's overrides: the user's, then the most precise precision a sweep asks
    for (if any), then --reference's (which win)."""
    swept = [value for setting in all_settings for key, value in setting.values if key == PRECISION_KEY]
    precision = [f'{PRECISION_KEY}="{"float64" if "float64" in swept else swept[0]}"'] if swept else []
    return list(options.overrides) + precision + list(options.reference)


def _without_precision(overrides: list[str]) -> tuple[str, ...]:
    return tuple(o for o in overrides if not o.startswith(PRECISION_KEY + "="))


def _reference(path: Path, options: StudyOptions, all_settings: list[Setting], rows_min_error) -> tuple[Bake, dict]:
    base = _load(path, list(options.overrides), options.frames)
    frequencies = [_scene_frequency(base)]
    for setting in all_settings:
        for key, value in setting.values:
            if key == "solver.frequency" and isinstance(value, (int, float)):
                frequencies.append(float(value))
    frequency = options.reference_frequency or 8.0 * max(frequencies)
    overrides = _reference_overrides(options, all_settings)
    history = []
    previous = None
    for attempt in range(options.reference_doublings + 1):
        scene = _load(path, overrides + [f"solver.frequency={frequency!r}"], options.frames)
        current = _bake_once(scene)
        if previous is not None:
            change, _ = position_errors(previous.frames, current.frames, _cloth_size(current))
            history.append({"frequency": frequency, "change_from_half": change})
            if change < 0.1 * rows_min_error(current):
                return current, _reference_info(path, options, overrides, frequency, scene, current, True, history)
        previous, previous_scene = current, scene
        frequency *= 2.0
    return previous, _reference_info(path, options, overrides, frequency / 2.0, previous_scene, previous, False, history)


def _reference_info(path: Path, options: StudyOptions, overrides: list[str], frequency: float, scene: Scene,
                    reference: Bake, converged: bool, history: list) -> dict:
    """What the table says about the reference, with its own round-off: measured by baking it
    again in float64 when it ran in float32, else estimated."""
    precision = scene.solver.precision
    size = _cloth_size(reference)
    if precision == "float32":
        twin_scene = _load(path, overrides + [f"solver.frequency={frequency!r}", f'{PRECISION_KEY}="float64"'],
                           options.frames)
        value = position_errors(reference.frames, _bake_once(twin_scene).frames, size)[0]
        source = roundoff.MEASURED
    else:
        iterations = reference.report["iterations_per_frame"] * reference.report["frames"]["simulated"]
        value = roundoff.estimate(precision, iterations, roundoff.extent(reference.frames), size)
        source = roundoff.ESTIMATED
    return {"frequency": frequency, "converged": converged, "history": history, "overrides": overrides,
            "precision": precision, "roundoff": value, "roundoff_source": source}


def run_study(
    scene_path: str | Path, options: StudyOptions, progress=None, previous: Previous | None = None
) -> StudyResult:
    """Bake every setting ``repeats`` times and the reference; return the table's rows.

    With ``previous`` (an earlier study of the same scene and reference), its reference is
    reused and its rows are kept: a setting baked again replaces its old row.
    """
    if options.metric not in METRICS:
        raise ClothtoolError(f"--metric {options.metric}: use one of {', '.join(METRICS)}")
    if options.repeats < 1:
        raise ClothtoolError("--repeats must be at least 1")
    if options.target_error is not None and not (options.target_error > 0 and math.isfinite(options.target_error)):
        raise ClothtoolError(f"--target-error {options.target_error:g}: give a positive error, e.g. 0.01")
    path = Path(scene_path)
    all_settings = settings(list(options.sweeps))
    baked: list[tuple[Setting, list[Bake] | str, str]] = []
    for i, setting in enumerate(all_settings):
        try:
            scene = _load(path, list(options.overrides) + setting.overrides, options.frames)
        except ClothtoolError as exc:
            raise ClothtoolError(f"--sweep setting {setting.as_dict()}: {exc}") from None
        runs: list[Bake] | str = []
        for _ in range(options.repeats):
            try:
                runs.append(_bake_once(scene))
            except UnstableError as exc:
                runs = str(exc)
                break
        baked.append((setting, runs, scene.solver.precision))
        if progress:
            progress(i + 1, len(all_settings) + 1)
    twins = _float64_twins(path, options, baked)

    def min_error(reference: Bake) -> float:
        size = _cloth_size(reference)
        errors = [
            position_errors(runs[0].frames, reference.frames, size)[0]
            for _, runs, _ in baked if not isinstance(runs, str)
        ]
        errors = [e for e in errors if e > 0 and math.isfinite(e)]
        return min(errors) if errors else 0.0

    if previous is not None:
        base = _load(path, list(options.overrides), options.frames)
        # the reference is reused whatever precision it ran in (the table says which)
        wanted = _without_precision(list(options.overrides) + list(options.reference))
        if previous.scene != base.name or _without_precision(previous.reference.get("overrides", [])) != wanted:
            raise ClothtoolError(
                f"{previous.where}: the study there is of scene '{previous.scene}' with reference overrides "
                f"{previous.reference.get('overrides')}; --append needs the same scene, --set and --reference"
            )
        reference = Bake(previous.reference_frames, {}, previous.reference.get("wall_s", 0.0), ())
        reference_info = dict(previous.reference)
        # studies from before precisions were recorded forced their reference to float64
        reference_info.setdefault("precision", "float64")
        reference_info.setdefault("roundoff", 0.0)
        reference_info.setdefault("roundoff_source", None)
    else:
        reference, reference_info = _reference(path, options, all_settings, min_error)
    if progress:
        progress(len(all_settings) + 1, len(all_settings) + 1)
    size = _cloth_size(reference)
    base = _load(path, list(options.overrides), options.frames)
    rows = [
        _failed_row(setting, runs, precision) if isinstance(runs, str)
        else _row(setting, runs, reference, size, base, precision, twins.get(i))
        for i, (setting, runs, precision) in enumerate(baked)
    ]
    if previous is not None:
        fresh = {(r["family"], r["label"]) for r in rows}
        rows = [r for r in previous.rows if (r["family"], r["label"]) not in fresh] + rows
    reference_info["cloth_size"] = size
    reference_info["wall_s"] = reference.wall_s
    key = METRIC_KEYS[options.metric]
    _mark_floor(rows, key, reference_info["roundoff"])
    target = None
    if options.target_error is not None:
        target = {"error": options.target_error, "metric": options.metric,
                  "families": time_to_error(rows, key, options.target_error)}
    return StudyResult(
        scene=base.name,
        metric=options.metric,
        rows=rows,
        reference=reference_info,
        machine=machine_info(),
        sweeps=[{"key": s.key, "values": list(s.values)} for s in options.sweeps],
        reference_frames=reference.frames,
        target=target,
    )


def _float64_twins(path: Path, options: StudyOptions, baked: list) -> dict[int, Bake]:
    """For each float32 setting (by index), a float64 bake of the same setting: a swept one
    when the sweep has it, else baked here (None when that goes unstable)."""
    swept64 = {
        _without_precision(setting.overrides): runs[0] for setting, runs, precision in baked
        if precision == "float64" and not isinstance(runs, str)
    }
    twins = {}
    for i, (setting, runs, precision) in enumerate(baked):
        if precision != "float32" or isinstance(runs, str):
            continue
        same = _without_precision(setting.overrides)
        if same not in swept64:
            scene = _load(path, list(options.overrides) + setting.overrides + [f'{PRECISION_KEY}="float64"'],
                          options.frames)
            try:
                swept64[same] = _bake_once(scene)
            except UnstableError:
                swept64[same] = None
        twins[i] = swept64[same]
    return twins
