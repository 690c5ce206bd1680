"""Summaries of fabrics for people (text) and machines (JSON-ready dicts)."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from clothtool.errors import FabricError
from clothtool.fabric import Fabric, PhaseType


def _constraint_counts_per_particle(pairs: np.ndarray, movable: np.ndarray, n: int) -> int:
    used = pairs.reshape(-1)
    used = used[movable[used]]
    return int(np.bincount(used, minlength=n).max()) if used.size else 0


def fabric_summary(fabric: Fabric) -> dict:
    """Particles, phases (type, constraints, sets vs lower bound), tethers, pins, bounds, validity."""
    n = fabric.particle_count
    movable = fabric.particle_inv_mass > 0
    # One row per phase type: a big cloth's fabric lists each type once per cache tile
    # (clothtool.cook.tiles); sets are counted over its tiles.
    phases = []
    for phase_type in dict.fromkeys(fabric.phase_type.tolist()):
        tiles = np.flatnonzero(fabric.phase_type == phase_type)
        pairs = np.concatenate([fabric.constraint_indices[fabric.phase_constraints(i)] for i in tiles.tolist()])
        sets = int(sum(fabric.phase_set_offsets[i + 1] - fabric.phase_set_offsets[i] for i in tiles.tolist()))
        phases.append(
            {
                "type": PhaseType(int(phase_type)).label,
                "constraints": int(pairs.shape[0]),
                "sets": sets,
                "sets_lower_bound": _constraint_counts_per_particle(pairs, movable, n),
                "tiles": int(tiles.shape[0]),
            }
        )
    try:
        fabric.validate()
        validation = "ok"
    except FabricError as exc:
        validation = str(exc)
    k = fabric.tethers_per_particle
    active_tethers = 0
    if k:
        owners = np.arange(fabric.tether_anchor.shape[0]) % n
        active_tethers = int(np.count_nonzero(fabric.tether_anchor != owners))
    lo = fabric.rest_pos.min(axis=0) if n else np.zeros(3)
    hi = fabric.rest_pos.max(axis=0) if n else np.zeros(3)
    finite_md = np.isfinite(fabric.particle_max_distance)
    return {
        "kind": "fabric",
        "particles": n,
        "pinned": int(np.count_nonzero(~movable)),
        "triangles": int(fabric.triangles.shape[0]),
        "faces": int(fabric.face_vertex_counts.shape[0]),
        "has_uv": bool(fabric.face_vertex_uv.shape[0]),
        "phases": phases,
        "constraints": fabric.constraint_count,
        "sets": fabric.set_count,
        "tethers_per_particle": k,
        "tethers": active_tethers,
        "max_distance_constrained": int(np.count_nonzero(finite_md)),
        "virtual_particles": int(fabric.virtual_particles.shape[0]),
        "virtual_batches": int(fabric.virtual_batch_offsets.shape[0] - 1),
        "bounding_box": {"min": [float(v) for v in lo], "max": [float(v) for v in hi]},
        "meters_per_unit": float(fabric.meters_per_unit),
        "up_axis": fabric.up_axis,
        "total_area_m2": float(fabric.particle_area.astype(np.float64).sum()),
        "source_sha256": fabric.source_sha256,
        "validation": validation,
    }


def format_fabric_summary(summary: dict, name: str) -> str:
    lines = [
        f"fabric {name}",
        f"  particles  {summary['particles']} ({summary['pinned']} pinned), "
        f"{summary['faces']} faces, {summary['triangles']} triangles, uv: {'yes' if summary['has_uv'] else 'no'}",
        f"  units      {summary['meters_per_unit']:g} m per unit, up axis {summary['up_axis']}, "
        f"area {summary['total_area_m2']:.4g} m^2",
    ]
    bb = summary["bounding_box"]
    lines.append(
        "  bounds     min (" + ", ".join(f"{v:.4g}" for v in bb["min"]) + ")  max ("
        + ", ".join(f"{v:.4g}" for v in bb["max"]) + ")"
    )
    lines.append(f"  phases     {len(summary['phases'])}, {summary['constraints']} constraints in {summary['sets']} sets")
    for phase in summary["phases"]:
        lines.append(
            f"    {phase['type']:<11} {phase['constraints']:>9} constraints  {phase['sets']:>3} sets "
            f"(lower bound {phase['sets_lower_bound']}"
            + (f", in {phase['tiles']} cache tiles)" if phase["tiles"] > 1 else ")")
        )
    lines.append(
        f"  tethers    {summary['tethers_per_particle']} per particle, {summary['tethers']} active"
    )
    if summary["max_distance_constrained"]:
        lines.append(f"  motion     {summary['max_distance_constrained']} particles with a max distance")
    if summary["virtual_particles"]:
        lines.append(
            f"  virtual    {summary['virtual_particles']} virtual particles in {summary['virtual_batches']} batches"
        )
    lines.append(f"  validation {summary['validation']}")
    return "\n".join(lines)


def _hdf5_format(path: Path) -> str | None:
    import h5py

    try:
        with h5py.File(path, "r") as f:
            value = f.attrs.get("format")
    except OSError:
        return None
    return value.decode() if isinstance(value, bytes) else value


def summarize_file(path: str | os.PathLike) -> tuple[dict, str]:
    """(JSON-ready summary, text) of a fabric or a cache, recognised by suffix and header."""
    from clothtool.errors import FormatError
    from clothtool.io.cache import read_cache, supported_suffixes

    path = Path(path)
    if not path.is_file():
        raise FormatError(f"{path}: file not found; check the path")
    suffix = path.suffix.lower()
    if suffix not in supported_suffixes():
        raise FormatError(f"{path}: unknown file type '{suffix}'; inspect reads fabrics (.fabric.h5) and caches ({', '.join(supported_suffixes())})")
    if suffix in (".h5", ".hdf5") and _hdf5_format(path) != "clothtool-cache":
        from clothtool.io.fabric_file import read_fabric

        summary = fabric_summary(read_fabric(path))
        return summary, format_fabric_summary(summary, path.name)
    from clothtool.io.cache_common import format_cache_summary

    with read_cache(path) as cache:
        summary = cache.summary()
    return summary, format_cache_summary(summary, path.name)
