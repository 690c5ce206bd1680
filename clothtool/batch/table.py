"""Text tables of a batch: the one-line-per-job summary that ``inspect`` prints for a
manifest, and the end-of-batch summary with every failed job's error line."""

from __future__ import annotations

COLUMNS = ("job", "status", "wall s", "cpu s", "max strain", "max speed", "finite")


def _cells(entry: dict) -> list[str]:
    stats = entry.get("stats") or {}
    timing = entry.get("timing") or {}

    def number(key, fmt):
        return format(stats[key], fmt) if isinstance(stats.get(key), (int, float)) else "-"

    finite = stats.get("finite")
    return [
        entry["id"],
        entry["status"],
        format(timing.get("wall_s", 0.0), ".2f"),
        format(timing.get("cpu_s", 0.0), ".2f"),
        number("max_strain", ".4f"),
        number("max_speed", ".3g"),
        "-" if finite is None else ("yes" if finite else "NO"),
    ]


def format_manifest_table(document: dict) -> str:
    """One row per job, then the totals and each failure's error line."""
    rows = [list(COLUMNS)] + [_cells(e) for e in document["jobs"]]
    widths = [max(len(row[i]) for row in rows) for i in range(len(COLUMNS))]
    lines = ["  ".join(cell.ljust(w) if i < 2 else cell.rjust(w) for i, (cell, w) in enumerate(zip(row, widths))).rstrip()
             for row in rows]
    lines.insert(1, "  ".join("-" * w for w in widths))
    total = document["summary"]
    lines.append(f"{total['jobs']} jobs: {total['ok']} ok, {total['failed']} failed; "
                 f"{total['wall_s']:.1f} s wall, {total['cpu_s']:.1f} s CPU in the jobs")
    lines += failure_lines(document["jobs"])
    return "\n".join(lines)


def failure_lines(entries: list[dict]) -> list[str]:
    failed = [e for e in entries if e["status"] != "ok"]
    if not failed:
        return []
    return ["failed:"] + [f"  {e['id']}: {e['error']}" for e in failed]


def format_batch_summary(entries: list[dict], skipped: list[str], manifest: str | None, wall_s: float) -> str:
    ok = sum(e["status"] == "ok" for e in entries)
    line = f"batch: {len(entries)} jobs, {ok} ok"
    if skipped:
        line += f" ({len(skipped)} up to date, skipped)"
    line += f", {len(entries) - ok} failed in {wall_s:.1f} s"
    if manifest:
        line += f"; manifest {manifest}"
    return "\n".join([line] + failure_lines(entries))
