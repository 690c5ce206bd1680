"""The HTML bake report: one self-contained page (inline SVG plots, no scripts, no fetches).

Every figure the JSON report carries is on the page: strain (max/mean/p99) per phase type,
tether stretch, max speed, kinetic energy, the NaN check, stages, iterations, wall/CPU time,
frames/s and particle-iterations/s. Each value cell names its JSON path in ``data-key``
(``overall/skirt/strain/vertical/max``) so tests can check the page against the JSON.

Same report, same bytes: matplotlib's SVG ids are salted with a fixed string and carry no date.
"""

from __future__ import annotations

import html
import io

from clothtool.profile import JIT_STAGE

# Wraps anything long (scene names, failure messages) instead of overflowing its box; wide
# tables scroll inside their own box; plots shrink to the page width.
STYLE = """
body{font-family:system-ui,sans-serif;max-width:64em;margin:2em auto;padding:0 1em;color:#222;overflow-wrap:anywhere}
h1{font-size:1.5em}h2{font-size:1.2em;margin-top:1.6em;border-bottom:1px solid #ddd}
.scroll{overflow-x:auto;max-width:100%}
table{border-collapse:collapse;margin:0.4em 0}
th,td{border:1px solid #ddd;padding:0.25em 0.6em;text-align:left;vertical-align:top}
td.num,th.num{text-align:right;font-variant-numeric:tabular-nums;white-space:nowrap}
th{background:#f4f4f4;white-space:nowrap}  /* labels are short: keep words whole */
.bad{color:#a00;font-weight:bold}.ok{color:#060}
figure{margin:1em 0}figure svg{max-width:100%;height:auto}
"""


def _cell(key: str, text: str, numeric: bool = True, css: str = "") -> str:
    classes = " ".join(c for c in ("num" if numeric else "", css) if c)
    attr = f' class="{classes}"' if classes else ""
    return f'<td{attr} data-key="{html.escape(key)}">{html.escape(text)}</td>'


def _percent(value: float) -> str:
    return f"{100 * value:.2f}%"


def _table(head: list[str], rows: list[str], numeric_from: int = 1) -> str:
    header = "".join(
        f'<th{" class=num" if i >= numeric_from else ""}>{html.escape(h)}</th>' for i, h in enumerate(head)
    )
    return f'<div class="scroll"><table><thead><tr>{header}</tr></thead><tbody>\n' + "\n".join(rows) + "\n</tbody></table></div>"


def _row(label: str, *cells: str) -> str:
    return f"<tr><th>{html.escape(label)}</th>{''.join(cells)}</tr>"


def _first_nonfinite(report: dict, name: str) -> str:
    for frame in report["per_frame"]:
        stats = frame["cloths"].get(name)
        if stats is not None and not stats["finite"]:
            return f"NaN/Inf at frame {frame['frame']} (particle {stats.get('nonfinite_particle', -1)})"
    return "NaN/Inf found"


def _summary_section(report: dict) -> str:
    frames, timing = report["frames"], report["timing"]
    ok = report["status"] == "ok"
    rows = [
        _row("status", _cell("status", report["status"], False, "ok" if ok else "bad")),
        _row("output", _cell("output", report["output"], False)),
        _row("frames", _cell("frames", f"{frames['start']}..{frames['end']} at {frames['fps']:g} fps", False)),
        _row("frames simulated", _cell("frames/simulated", str(frames["simulated"]))),
        _row("iterations per frame", _cell("iterations_per_frame", str(report["iterations_per_frame"]))),
        _row("stages that ran", _cell("stages", ", ".join(report["stages"]), False)),
        _row("wall time", _cell("timing/wall_s", f"{timing['wall_s']:.2f} s")),
        _row("JIT warm-up (once)", _cell("timing/jit_warm_up_s", f"{timing['jit_warm_up_s']:.2f} s")),
        _row("simulation time", _cell("timing/simulation_s", f"{timing['simulation_s']:.2f} s")),
        _row("CPU time", _cell("timing/cpu_s", f"{timing['cpu_s']:.2f} s")),
        _row("frames per second", _cell("timing/frames_per_second", f"{timing['frames_per_second']:.1f}")),
        _row(
            "particle-iterations per second",
            _cell("timing/particle_iterations_per_second", f"{timing['particle_iterations_per_second'] / 1e6:.3f} M"),
        ),
    ]
    if report["failure"]:
        rows.append(_row("failure", _cell("failure/message", report["failure"]["message"], False, "bad")))
    if report["partial_output"]:
        rows.append(_row("frames so far kept in", _cell("partial_output", report["partial_output"], False)))
    return "<h2>Summary</h2>\n" + _table(["", "value"], rows)


def _cloth_section(report: dict, name: str, overall: dict) -> str:
    key = f"overall/{name}"
    info = report["cloths"].get(name, {})
    finite = overall["finite"]
    rows = [
        _row("particles", _cell(f"cloths/{name}/particles", str(info.get("particles", "")))),
        _row("constraints", _cell(f"cloths/{name}/constraints", str(info.get("constraints", "")))),
        _row("max speed", _cell(f"{key}/max_speed", f"{overall['max_speed']:.3g} m/s")),
        _row("max kinetic energy", _cell(f"{key}/max_kinetic_energy", f"{overall['max_kinetic_energy']:.3g} J")),
    ]
    if "max_tether_stretch" in overall:
        rows.append(_row("max tether stretch", _cell(f"{key}/max_tether_stretch", _percent(overall["max_tether_stretch"]))))
    rows.append(
        _row(
            "NaN check",
            _cell(f"{key}/finite", "all positions finite" if finite else _first_nonfinite(report, name), False,
                  "ok" if finite else "bad"),
        )
    )
    rows.append(_row("frames asleep", _cell(f"{key}/asleep_frames", str(overall["asleep_frames"]))))
    strain_rows = [
        _row(label, *(_cell(f"{key}/strain/{label}/{stat}", _percent(s[stat]) if stat in s else "-")
                      for stat in ("max", "mean", "p99")))
        for label, s in overall["strain"].items()
    ]
    return (
        f"<h2>Cloth {html.escape(name)}</h2>\n"
        + _table(["", "value"], rows)
        + "\n<h3>Strain per phase type (over all frames)</h3>\n"
        + _table(["phase type", "max", "mean", "p99"], strain_rows)
    )


def _profile_section(report: dict) -> str:
    rows = []
    for index, row in enumerate(report["profile"]):
        key = f"profile/{index}"
        jit = row["stage"] == JIT_STAGE
        # JIT warm-up happens once: per frame it means nothing, its total is what matters
        rows.append(
            _row(
                row["stage"],
                _cell(f"{key}/total_s", f"{row['total_s']:.3f} s"),
                _cell(f"{key}/per_frame_ms", "-" if jit else f"{row['per_frame_ms']:.3f} ms"),
                _cell(f"{key}/share", "-" if jit else f"{100 * row['share']:.1f}%"),
                _cell(f"{key}/calls", str(row["calls"])),
            )
        )
    return "<h2>Time per stage</h2>\n" + _table(["stage", "total", "per frame", "share", "calls"], rows)


# ------------------------------------------------------------------------------ plots
def _svg(figure) -> str:
    import matplotlib

    buffer = io.StringIO()
    with matplotlib.rc_context({"svg.hashsalt": "clothtool", "svg.fonttype": "none"}):
        figure.savefig(buffer, format="svg", metadata={"Date": None}, bbox_inches="tight")
    text = buffer.getvalue()
    return text[text.index("<svg") :]


def _series(report: dict, name: str, pick) -> tuple[list[int], list[float]]:
    frames, values = [], []
    for frame in report["per_frame"]:
        stats = frame["cloths"].get(name)
        if stats is not None:
            frames.append(frame["frame"])
            values.append(pick(stats))
    return frames, values


def _curve_plot(plt, ylabel: str, lines) -> str:
    """``lines``: (label, frames, values, style kwargs) per curve; the page's heading is the title."""
    fig, ax = plt.subplots(figsize=(8, 3))
    for label, frames, values, style in lines:
        ax.plot(frames, values, label=label, **style)
    ax.set_xlabel("frame")
    ax.set_ylabel(ylabel)
    ax.grid(alpha=0.3)
    if len(lines) > 1:
        ax.legend(fontsize=7, loc="center left", bbox_to_anchor=(1.01, 0.5))
    svg = _svg(fig)
    plt.close(fig)
    return svg


def _plots(report: dict) -> list[tuple[str, str]]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = [n for n in report["cloths"] if n in report["overall"]]
    plots = []
    if report["per_frame"] and names:
        colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
        strain_lines, curve = [], 0
        for name in names:
            for label in report["overall"][name]["strain"]:
                colour = colours[curve % len(colours)]  # max and p99 of one phase type share a colour
                curve += 1
                prefix = f"{name} {label}" if len(names) > 1 else label
                frames, maxima = _series(report, name, lambda s, phase=label: 100 * s["strain"][phase]["max"])
                strain_lines.append((f"{prefix} max", frames, maxima, {"color": colour}))
                if "p99" in report["overall"][name]["strain"][label]:
                    frames, p99 = _series(report, name, lambda s, phase=label: 100 * s["strain"][phase]["p99"])
                    strain_lines.append((f"{prefix} p99", frames, p99, {"color": colour, "linestyle": "--"}))
        plots.append(("Strain per phase type (max; p99 dashed)", _curve_plot(plt, "strain (%)", strain_lines)))
        plots.append(("Max particle speed", _curve_plot(
            plt, "m/s", [(name, *_series(report, name, lambda s: s["max_speed"]), {}) for name in names],
        )))
        plots.append(("Kinetic energy", _curve_plot(
            plt, "J", [(name, *_series(report, name, lambda s: s["kinetic_energy"]), {}) for name in names],
        )))
        tethered = [n for n in names if "max_tether_stretch" in report["overall"][n]]
        if tethered:
            plots.append(("Max tether stretch", _curve_plot(
                plt, "stretch (%)",
                [(name, *_series(report, name, lambda s: 100 * s["tether_stretch"]), {}) for name in tethered],
            )))
    rows = [r for r in report["profile"] if r["stage"] != JIT_STAGE]
    if rows:
        fig, ax = plt.subplots(figsize=(8, 0.4 * len(rows) + 1))
        ax.barh([r["stage"] for r in rows], [r["per_frame_ms"] for r in rows], color="#4a7ab5")
        ax.invert_yaxis()
        ax.set_xlabel("ms per frame")
        ax.grid(alpha=0.3, axis="x")
        plots.append(("Time per stage per frame (JIT warm-up apart)", _svg(fig)))
        plt.close(fig)
    return plots


def render_html(report: dict) -> str:
    """The whole page for ``report`` (the dict of ``BakeStats.to_dict``)."""
    scene = html.escape(report["scene"])
    sections = [_summary_section(report)]
    sections += [_cloth_section(report, name, overall) for name, overall in report["overall"].items()]
    sections.append(_profile_section(report))
    sections += [f'<h2>{html.escape(title)}</h2>\n<figure>{svg}</figure>' for title, svg in _plots(report)]
    body = "\n".join(sections)
    return f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><meta name="viewport" content="width=device-width">
<title>clothtool bake report: {scene}</title>
<style>{STYLE}</style>
</head><body>
<h1>Bake report: {scene} <small>(clothtool {html.escape(str(report.get('clothtool', '')))})</small></h1>
{body}
</body></html>"""
