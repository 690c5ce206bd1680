"""Bake reports: a text summary, JSON (``--report x.json`` / ``--json``) and HTML with plots.

Reports carry durations but no timestamps, host names or absolute paths.
"""

from __future__ import annotations

import html
import io
import json
import os
from pathlib import Path

from clothtool.errors import ClothtoolError
from clothtool.io.atomic import atomic_output
from clothtool.profile import format_profile

REPORT_SUFFIXES = (".json", ".html")


def format_summary(report: dict) -> str:
    """A few lines for people: what ran, how fast, how well."""
    timing = report["timing"]
    frames = report["frames"]
    lines = [
        f"bake {report['scene']} -> {report['output']}: {report['status']}",
        f"  frames     {frames['start']}..{frames['end']} ({frames['simulated']} simulated at {frames['fps']:g} fps), "
        f"{report['iterations_per_frame']} iterations per frame",
        f"  stages     {', '.join(report['stages'])}",
        f"  time       {timing['wall_s']:.2f} s wall ({timing['jit_warm_up_s']:.2f} s JIT warm-up), "
        f"{timing['cpu_s']:.2f} s CPU, {timing['frames_per_second']:.1f} frames/s, "
        f"{timing['particle_iterations_per_second'] / 1e6:.2f} M particle-iterations/s",
    ]
    for name, cloth in report["overall"].items():
        strain = ", ".join(f"{label} {100 * s['max']:.2f}%" for label, s in cloth["strain"].items())
        lines.append(
            f"  {name:<10} max strain {strain}; max speed {cloth['max_speed']:.3g} m/s"
            + (f"; tether stretch {100 * cloth['max_tether_stretch']:.2f}%" if "max_tether_stretch" in cloth else "")
        )
    if report["failure"]:
        lines.append(f"  failure    {report['failure']['message']}")
    if report["partial_output"]:
        lines.append(f"  partial    frames so far kept in {report['partial_output']}")
    return "\n".join(lines)


def format_profile_table(report: dict) -> str:
    return format_profile(report["profile"])


def _check_path(path: Path) -> None:
    if path.suffix.lower() not in REPORT_SUFFIXES:
        raise ClothtoolError(f"{path}: report format '{path.suffix}' is not supported; use .json or .html")


def check_report_path(path: str | os.PathLike) -> Path:
    path = Path(path)
    _check_path(path)
    from clothtool.io.atomic import check_output_path

    return check_output_path(path)


def write_report(report: dict, path: str | os.PathLike) -> None:
    """Write ``report`` as JSON or HTML (by suffix), atomically."""
    path = check_report_path(path)
    text = json.dumps(report, indent=2, sort_keys=True) if path.suffix.lower() == ".json" else render_html(report)
    with atomic_output(path, "writing the report") as tmp:
        tmp.write_text(text + "\n", encoding="utf-8")


# ------------------------------------------------------------------------------ HTML
def _svg(figure) -> str:
    import matplotlib

    buffer = io.StringIO()
    with matplotlib.rc_context({"svg.hashsalt": "clothtool", "svg.fonttype": "none"}):
        figure.savefig(buffer, format="svg", metadata={"Date": None}, bbox_inches="tight")
    text = buffer.getvalue()
    return text[text.index("<svg") :]


def _plots(report: dict) -> list[tuple[str, str]]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    frames = [f["frame"] for f in report["per_frame"]]
    plots = []
    if frames:
        for title, key in (("Max strain per phase type", "strain"), ("Kinetic energy (J)", "kinetic_energy")):
            fig, ax = plt.subplots(figsize=(7, 3))
            for name in report["cloths"]:
                series = [f["cloths"].get(name) for f in report["per_frame"]]
                if key == "strain":
                    labels = series[0]["strain"].keys() if series and series[0] else []
                    for label in labels:
                        ax.plot(frames, [100 * s["strain"][label]["max"] for s in series], label=f"{name} {label}")
                    ax.set_ylabel("strain (%)")
                else:
                    ax.plot(frames, [s[key] for s in series], label=name)
                    ax.set_ylabel("J")
            ax.set_xlabel("frame")
            ax.set_title(title)
            ax.grid(alpha=0.3)
            ax.legend(fontsize=7)
            plots.append((title, _svg(fig)))
            plt.close(fig)
    rows = [r for r in report["profile"] if r["stage"] != "jit warm-up"]
    if rows:
        fig, ax = plt.subplots(figsize=(7, 0.4 * len(rows) + 1))
        ax.barh([r["stage"] for r in rows], [r["per_frame_ms"] for r in rows], color="#4a7ab5")
        ax.invert_yaxis()
        ax.set_xlabel("ms per frame")
        ax.set_title("Stage time")
        ax.grid(alpha=0.3, axis="x")
        plots.append(("Stage time", _svg(fig)))
        plt.close(fig)
    return plots


def render_html(report: dict) -> str:
    summary = html.escape(format_summary(report))
    profile = html.escape(format_profile_table(report))
    figures = "\n".join(f"<h2>{html.escape(title)}</h2>\n{svg}" for title, svg in _plots(report))
    return f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>clothtool bake report: {html.escape(report['scene'])}</title>
<style>body{{font-family:sans-serif;max-width:60em;margin:2em auto}} pre{{background:#f4f4f4;padding:1em}}</style>
</head><body>
<h1>Bake report: {html.escape(report['scene'])}</h1>
<pre>{summary}</pre>
<h2>Profile</h2>
<pre>{profile}</pre>
{figures}
</body></html>"""
