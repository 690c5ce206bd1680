"""A wedge's outputs side by side: the study's work-precision table over a baked batch.

Bake jobs in a manifest that share their scene and settings apart from the wedge form a
group. Each wedge's cache is compared, frame by frame, with the group's reference: the
wedge with the highest solver frequency (the most converged), or one named by its job id.
Errors are the study's (RMS and max particle distance over the common frames, divided by
the cloth's size), time is the job's wall time from the manifest.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

from clothtool.errors import ClothtoolError


def wedge_groups(document: dict) -> list[list[dict]]:
    """Bake entries grouped by scene and non-wedge settings, groups and members in order."""
    groups: dict[str, list[dict]] = {}
    for entry in document["jobs"]:
        if entry["kind"] != "bake" or not entry["settings"].get("wedge"):
            continue
        settings = {k: v for k, v in entry["settings"].items() if k != "wedge"}
        key = json.dumps([entry["input"], settings], sort_keys=True)
        groups.setdefault(key, []).append(entry)
    return list(groups.values())


def _frequency(entry: dict) -> float:
    return float(entry.get("resolved", {}).get("solver", {}).get("frequency", -math.inf))


def _frames(path: Path) -> tuple[dict[int, tuple], float]:
    """Every frame's points per cloth (in header order) and the cloths' size at the first."""
    import numpy as np

    from clothtool.io.cache import read_cache

    with read_cache(path) as cache:
        names = [c.name for c in cache.header.cloths]
        frames = {f: tuple(cache.points(n, f).astype(np.float64) for n in names) for f in cache.frames}
    first = np.vstack(frames[min(frames)])
    return frames, float(np.linalg.norm(first.max(axis=0) - first.min(axis=0))) or 1.0


def compare_group(group: list[dict], root: Path, reference_id: str | None = None) -> dict:
    """Rows (one per wedge) with time and error against the reference wedge."""
    from clothtool.study import position_errors

    done = [e for e in group if e["status"] == "ok"]
    if reference_id is not None:
        matches = [e for e in done if e["id"] == reference_id]
        if not matches:
            raise ClothtoolError(f"--reference-job {reference_id}: no finished bake of this wedge has that id; "
                                 f"use one of {', '.join(e['id'] for e in done)}")
        reference = matches[0]
    elif done:
        reference = max(done, key=_frequency)
    else:
        reference = None
    rows = []
    if reference is not None:
        ref_frames, size = _frames(root / reference["id"])
    for entry in group:
        row = {"id": entry["id"], "wedge": entry["settings"]["wedge"], "status": entry["status"],
               "wall_s": entry["timing"]["wall_s"], "max_strain": entry["stats"].get("max_strain", math.nan),
               "finite": entry["stats"].get("finite"), "position_rms": math.nan, "position_max": math.nan}
        if entry["status"] == "ok" and reference is not None:
            frames, _ = _frames(root / entry["id"])
            row["position_rms"], row["position_max"] = position_errors(frames, ref_frames, size)
        rows.append(row)
    return {"scene": group[0]["input"], "reference": reference["id"] if reference else None, "rows": rows}


def compare_manifest(path: str | Path, reference_id: str | None = None) -> list[dict]:
    from clothtool.batch.manifest import load_manifest_document

    path = Path(path)
    groups = wedge_groups(load_manifest_document(path))
    if not groups:
        raise ClothtoolError(f"{path}: the manifest has no wedged bakes to compare; bake with --wedge KEY=V1,V2,...")
    return [compare_group(group, path.parent, reference_id) for group in groups]


def format_comparison(tables: list[dict]) -> str:
    lines = []
    for table in tables:
        lines.append(f"wedge of {table['scene']}: errors against {table['reference']} (position / cloth size)")
        header = ("wedge", "wall s", "max strain", "pos rms", "pos max", "status")
        cells = [[", ".join(f"{k}={v}" for k, v in row["wedge"].items()), f"{row['wall_s']:.2f}",
                  f"{row['max_strain']:.4f}", f"{row['position_rms']:.3e}", f"{row['position_max']:.3e}",
                  row["status"] if row["finite"] is not False else "NaN"] for row in table["rows"]]
        widths = [max(len(r[i]) for r in [list(header)] + cells) for i in range(len(header))]
        for row in [list(header)] + cells:
            lines.append("  " + "  ".join(c.ljust(w) if i == 0 else c.rjust(w) for i, (c, w) in enumerate(zip(row, widths))))
    return "\n".join(lines)
