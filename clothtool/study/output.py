"""Study outputs: the work-precision table (text, CSV, JSON) and plot (PNG, SVG)."""

from __future__ import annotations

import csv
import io
import json
import math
from pathlib import Path

import numpy as np

from clothtool.errors import ClothtoolError
from clothtool.io.atomic import atomic_output
from clothtool.study import roundoff

# metric -> (row key plotted, axis label)
METRIC_COLUMNS = {
    "position": ("position_rms", "RMS position error / cloth size"),
    "strain": ("strain_max", "max strain"),
    "penetration": ("penetration_max", "max face penetration into spheres and capsules (m)"),
    "energy": ("energy_drift_J", "|energy drift| (J)"),
}
COLUMNS = (
    ("label", "setting"), ("family", "family"), ("precision", "precision"), ("wall_s_per_simulated_s", "s/sim s"),
    ("constraint_projections_per_simulated_s", "proj/sim s"), ("strain_max", "strain max"),
    ("strain_mean", "strain mean"), ("strain_p99", "strain p99"), ("position_rms", "pos rms"),
    ("position_max", "pos max"), ("penetration_max", "penetration"), ("energy_drift_J", "energy J"),
    ("floor", "floor"),
)
FLOOR_MARK = "#"  # after the error of a row at its round-off floor


def pareto_front(rows: list[dict], key: str) -> list[int]:
    """Indices of rows no other row beats on both time and error (failures excluded)."""
    good = [
        (r["wall_s_per_simulated_s"], abs(r[key]), i) for i, r in enumerate(rows)
        if not r["failed"] and math.isfinite(r[key]) and math.isfinite(r["wall_s_per_simulated_s"])
    ]
    front, best = [], math.inf
    for time_, error, i in sorted(good):
        if error < best:
            front.append(i)
            best = error
    return front


def _cell(value) -> str:
    if isinstance(value, float):
        return "nan" if math.isnan(value) else f"{value:.4g}"
    return str(value)


def format_table(result) -> str:
    key = METRIC_COLUMNS[result.metric][0]
    front = set(pareto_front(result.rows, key))
    widths = [max(len(title), 11) for _, title in COLUMNS]
    lines = [
        f"study {result.scene}: metric {result.metric}, median of the runs per point; * = Pareto front; "
        f"{FLOOR_MARK} = error at the round-off floor (at most {roundoff.FLOOR_MARGIN:g}x the run's and the "
        "reference's round-off: raising the frequency will not lower it)",
        "  ".join(title.rjust(w) for (_, title), w in zip(COLUMNS, widths)),
    ]
    column = [k for k, _ in COLUMNS].index(key)
    for i, row in enumerate(result.rows):
        cells = [_cell(row.get(k, "")) for k, _ in COLUMNS]
        cells[0] = ("*" if i in front else " ") + cells[0]
        if row.get("at_floor"):
            cells[column] += FLOOR_MARK
        lines.append("  ".join(c.rjust(w) for c, w in zip(cells, widths)))
    failures = [r for r in result.rows if r["failed"]]
    for row in failures:
        lines.append(f"FAILED {row['family']} {row['label']}: {row['failed']}")
    ref = result.reference
    changes = ", ".join(f"{h['change_from_half']:.3g}" for h in ref["history"]) or "n/a"
    status = "converged" if ref["converged"] else "NOT converged"
    lines.append(f"reference: {ref['frequency']:g} Hz, {ref.get('precision', 'float64')}, {status} "
                 f"(changes on doubling: {changes})")
    if ref.get("roundoff_source"):
        lines.append(f"reference round-off: {ref['roundoff']:.3g} ({ref['roundoff_source']})")
    sources = sorted({r["roundoff_source"] for r in result.rows if r.get("roundoff_source")})
    if sources:
        lines.append(f"floor = round-off of the {result.metric} error: " + "; ".join(sources)
                     + (", plus the reference's" if result.metric == "position" else ""))
    if result.target is not None:
        lines += format_target(result.target)
    resolved = _reference_resolution(result)
    if resolved is not None:
        lines.append(
            f"note: rows with position errors below {resolved:.3g} are as close to the reference as the reference "
            "is to itself on doubling; their true errors are not resolved"
        )
    m = result.machine
    lines.append(f"machine: {m['cpu']}, {m['cores']} cores, {m['system']}, python {m['python']}, numba {m['numba']}")
    return "\n".join(lines)


def format_target(target: dict) -> list[str]:
    """One line per family: the cheapest run reaching the target error and the time to it."""
    lines = [f"time to reach {target['metric']} error <= {target['error']:g} (wall s per simulated s):"]
    for answer in target["families"]:
        if not answer["reached"]:
            lines.append(f"  {answer['family']}: not reached (best {answer['best_error']:.4g})")
            continue
        how = ("at most, the cheapest swept run already reaches it" if answer["bound"] == "at most"
               else "interpolated in log-log between swept runs")
        lines.append(
            f"  {answer['family']}: {answer['wall_s_per_simulated_s']:.4g} ({how}); cheapest run {answer['run']} "
            f"at {answer['run_wall_s_per_simulated_s']:.4g}"
        )
    return lines


def _reference_resolution(result) -> float | None:
    """The reference's last change on doubling, if some row's position error is below 10x it
    (a row appended after the reference was judged converged can be that accurate)."""
    history = result.reference.get("history") or []
    if not history:
        return None
    change = history[-1]["change_from_half"]
    errors = [r["position_rms"] for r in result.rows if not r["failed"] and math.isfinite(r["position_rms"])]
    return change if errors and min(errors) < 10 * change else None


def _csv(result) -> str:
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    keys = [k for k, _ in COLUMNS] + ["at_floor", "roundoff_source", "failed"]
    setting_keys = []  # every swept key of every row (appended studies may sweep other keys)
    for row in result.rows:
        setting_keys += [k for k in row["setting"] if k not in setting_keys]
    writer.writerow(setting_keys + keys)
    for row in result.rows:
        writer.writerow([row["setting"].get(k, "") for k in setting_keys]
                        + [row.get(k) if row.get(k) is not None else "" for k in keys])
    return buffer.getvalue()


def _plot(result, suffix: str, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    key, label = METRIC_COLUMNS[result.metric]
    fig, ax = plt.subplots(figsize=(7.5, 5))
    families = []
    for row in result.rows:
        if row["family"] not in families:
            families.append(row["family"])
    for family in families:
        rows = [r for r in result.rows if r["family"] == family and not r["failed"] and math.isfinite(r[key]) and r[key] != 0]
        if not rows:
            continue
        xs = [r["wall_s_per_simulated_s"] for r in rows]
        ys = [abs(r[key]) for r in rows]
        line, = ax.plot(xs, ys, marker="o", label=family)
        for x, y, r in zip(xs, ys, rows):
            ax.annotate(r["label"], (x, y), textcoords="offset points", xytext=(4, 4), fontsize=7)
        # where round-off sets the floor: the floor itself (dotted) and the rows at it (ringed)
        floors = [(x, r["floor"]) for x, r in zip(xs, rows) if math.isfinite(r.get("floor", math.nan)) and r["floor"] > 0]
        if floors and any(r.get("roundoff_source") == roundoff.MEASURED for r in rows):
            ax.plot(*zip(*floors), ls=":", color=line.get_color(), lw=1, label=f"{family}: round-off floor")
        at = [(x, y) for x, y, r in zip(xs, ys, rows) if r.get("at_floor")]
        if at:
            ax.plot(*zip(*at), ls="none", marker="o", ms=12, mfc="none", mec="red", mew=1.2)
    if any(r.get("at_floor") for r in result.rows):
        ax.plot([], [], ls="none", marker="o", ms=12, mfc="none", mec="red", label="at the round-off floor")
    if result.target is not None:
        ax.axhline(result.target["error"], color="grey", lw=0.8, ls="-.", label=f"target {result.target['error']:g}")
        reached = [a for a in result.target["families"] if a["reached"]]
        if reached:
            ax.plot([a["wall_s_per_simulated_s"] for a in reached], [result.target["error"]] * len(reached),
                    ls="none", marker="*", ms=11, color="black", label="time to target")
    front = [result.rows[i] for i in pareto_front(result.rows, key) if result.rows[i][key] != 0]
    if front:
        ax.plot([r["wall_s_per_simulated_s"] for r in front], [abs(r[key]) for r in front], "k--", lw=1,
                label="Pareto front", alpha=0.6)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("wall time per simulated second (s)")
    ax.set_ylabel(label)
    title = f"{result.scene}: work-precision"
    failures = [f"{r['family']} {r['label']}" for r in result.rows if r["failed"]]
    if failures:
        title += "\nfailed: " + ", ".join(failures)
    ax.set_title(title, fontsize=9)
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8)
    with matplotlib.rc_context({"svg.hashsalt": "clothtool"}):
        fig.savefig(path, format=suffix, metadata={"Date": None} if suffix == "svg" else {"Software": None}, dpi=120,
                    bbox_inches="tight")
    plt.close(fig)


def save_reference(frames: dict, path: Path) -> None:
    """The reference bake's compared frames, so a later ``--append`` study can reuse them."""
    arrays = {f"frame{frame}_cloth{i}": points for frame, clouds in frames.items() for i, points in enumerate(clouds)}
    with atomic_output(path) as tmp:
        with open(tmp, "wb") as handle:
            np.savez_compressed(handle, **arrays)


def load_previous(out_dir: str | Path):
    """The study already in ``out_dir`` (for ``--append``); run_study checks it matches."""
    from clothtool.study import Previous

    out = Path(out_dir)
    table, saved = out / "table.json", out / "reference.npz"
    if not table.is_file() or not saved.is_file():
        raise ClothtoolError(f"{out}: --append needs an earlier study there (table.json and reference.npz); run without --append first")
    data = json.loads(table.read_text())
    frames: dict[int, list] = {}
    with np.load(saved) as npz:
        for name in npz.files:
            frame, cloth = name[len("frame"):].split("_cloth")
            frames.setdefault(int(frame), []).append((int(cloth), npz[name]))
    ordered = {f: tuple(points for _, points in sorted(clouds)) for f, clouds in frames.items()}
    return Previous(data["rows"], ordered, data["reference"], data["scene"], str(out))


def write_study(result, out_dir: str | Path) -> list[Path]:
    """Write table.txt/.csv/.json, plot.png/.svg and reference.npz into ``out_dir``
    (created if missing)."""
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise ClothtoolError(f"{out}: exists and is not a directory; give a directory for the study")
    out.mkdir(parents=True, exist_ok=True)
    written = []
    texts = {
        "table.txt": format_table(result) + "\n",
        "table.csv": _csv(result),
        "table.json": json.dumps(
            {"scene": result.scene, "metric": result.metric, "sweeps": result.sweeps, "rows": result.rows,
             "reference": result.reference, "machine": result.machine, "target": result.target},
            indent=2, sort_keys=True, default=float,
        ) + "\n",
    }
    for name, text in texts.items():
        with atomic_output(out / name) as tmp:
            tmp.write_text(text)
        written.append(out / name)
    for suffix in ("png", "svg"):
        with atomic_output(out / f"plot.{suffix}") as tmp:
            _plot(result, suffix, tmp)
        written.append(out / f"plot.{suffix}")
    if result.reference_frames:
        save_reference(result.reference_frames, out / "reference.npz")
        written.append(out / "reference.npz")
    return written
