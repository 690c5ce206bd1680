"""``clothtool study``: speed against error over swept settings."""

from __future__ import annotations

from pathlib import Path

import click

from clothtool.cli.bake import parse_frames
from clothtool.cli.common import emit_json, handle_errors, stderr_is_terminal
from clothtool.cli.progress import progress_bar


@click.command()
@click.argument("scene", type=click.Path(dir_okay=False, path_type=Path))
@click.option("--sweep", "sweeps", multiple=True, metavar="KEY=V1,V2,...",
              help="Values to try for a scene/preset key; the first sweep is the x variable, others make families.")
@click.option("--metric", type=click.Choice(["position", "strain", "penetration", "energy"]), default="position",
              show_default=True, help="Error plotted against time.")
@click.option("-o", "--output", type=click.Path(file_okay=False, path_type=Path),
              help="Directory for table.txt/.csv/.json and plot.png/.svg.")
@click.option("--repeats", type=click.IntRange(min=1), default=3, show_default=True, help="Bakes per point (median time).")
@click.option("--set", "overrides", multiple=True, metavar="KEY=VALUE", help="Override a key for every bake.")
@click.option("--reference", "reference", multiple=True, metavar="KEY=VALUE",
              help="Override a key for the reference bake only (e.g. solver.stiffness_mode=xpbd).")
@click.option("--reference-frequency", type=float, help="Reference solver frequency [8x the largest swept].")
@click.option("--frames", callback=parse_frames, metavar="START:END", help="Frame range for every bake.")
@click.option("--target-error", type=float, metavar="X",
              help="Report each family's time (wall s per simulated s) to reach an error <= X, interpolated in log-log.")
@click.option("--append", is_flag=True,
              help="Add to the study already in the output directory, reusing its reference (e.g. other families).")
@click.option("--reference-job", metavar="ID", help="Manifest mode: the job whose cache is the reference [highest frequency].")
@click.option("--json", "as_json", is_flag=True, help="Print the table as JSON on stdout.")
@handle_errors
def study(scene, sweeps, metric, output, repeats, overrides, reference, reference_frequency, frames, target_error, append,
          reference_job, as_json):
    """Bake SCENE for every swept setting and a converged reference; write a work-precision
    table and plot. Given a batch manifest (.json) instead, compare each wedge's caches side
    by side against its highest-frequency wedge.

    Every bake runs in the precision asked for (the reference in float64 when a sweep asks
    for it); rows whose error is at their round-off floor are marked.

    \b
    Examples:
      clothtool study examples/skirt/scene.toml --sweep solver.frequency=60,120,240,480 \\
          --sweep solver.stiffness_mode=nvcloth,xpbd --reference solver.stiffness_mode=xpbd -o out/study
      clothtool study examples/sheet/swing.toml --sweep solver.frequency=384,1536,6144 \\
          --sweep solver.precision=float32,float64 --target-error 0.005 -o out/precision
      clothtool study caches/manifest.json
    """
    if scene.suffix.lower() == ".json":
        from clothtool.batch.compare import compare_manifest, format_comparison

        tables = compare_manifest(scene, reference_job)
        emit_json(tables) if as_json else click.echo(format_comparison(tables))
        return
    if not sweeps:
        raise click.UsageError("Missing option '--sweep' (or give a batch manifest .json).")
    if output is None:
        raise click.UsageError("Missing option '-o' / '--output'.")
    from clothtool.study import StudyOptions, run_study
    from clothtool.study.output import format_table, load_previous, write_study
    from clothtool.study.sweep import Sweep

    options = StudyOptions(
        sweeps=tuple(Sweep.parse(s) for s in sweeps), metric=metric, repeats=repeats, overrides=tuple(overrides),
        reference=tuple(reference), reference_frequency=reference_frequency, frames=frames, target_error=target_error,
    )
    previous = load_previous(output) if append else None
    with progress_bar(stderr_is_terminal()) as update:
        result = run_study(scene, options, progress=update, previous=previous)
    write_study(result, output)
    if as_json:
        emit_json({"rows": result.rows, "reference": result.reference, "machine": result.machine, "target": result.target})
    else:
        click.echo(format_table(result))
