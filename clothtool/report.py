"""Bake reports: a text summary, JSON (``--report x.json`` / ``--json``) and HTML with plots.

Reports carry durations but no timestamps, host names or absolute paths.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

from clothtool.errors import UsageError
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
            + (
                f"; faces in colliders {1000 * cloth['max_penetration']:.2f} mm deep, beyond the thickness in "
                f"{cloth['frames_with_faces_beyond_thickness']} frames"
                if "max_penetration" in cloth else ""
            )
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
        raise UsageError(f"{path}: report format '{path.suffix}' is not supported; use .json or .html")


def check_report_path(path: str | os.PathLike) -> Path:
    path = Path(path)
    _check_path(path)
    from clothtool.io.atomic import check_output_path

    return check_output_path(path)


def write_report(report: dict, path: str | os.PathLike) -> None:
    """Write ``report`` as JSON or HTML (by suffix), atomically."""
    path = check_report_path(path)
    if path.suffix.lower() == ".json":
        text = json.dumps(report, indent=2, sort_keys=True)
    else:
        from clothtool.report_html import render_html  # matplotlib loads only for HTML

        text = render_html(report)
    with atomic_output(path, "writing the report") as tmp:
        tmp.write_text(text + "\n", encoding="utf-8")
