"""``clothtool bake``: simulate a scene into an HDF5 or USD cache."""

from __future__ import annotations

import contextlib
import sys
from pathlib import Path

import click

from clothtool.cli.common import emit_json, handle_errors, raise_if_interrupted, stderr_is_terminal, warn


def parse_frames(ctx, param, value):
    if value is None:
        return None
    try:
        start, end = (int(v) for v in value.split(":"))
    except ValueError:
        raise click.BadParameter(f"'{value}' is not START:END, e.g. 1:48") from None
    return start, end


@contextlib.contextmanager
def progress_bar(enabled: bool):
    """A rich progress bar on stderr when it is a terminal; yields a progress callback, which
    also ends the bake when a termination signal came (see ``raise_if_interrupted``)."""
    if not enabled:
        yield lambda done, total: raise_if_interrupted()
        return
    from rich.console import Console
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TimeRemainingColumn

    with Progress(
        "[progress.description]{task.description}", BarColumn(), MofNCompleteColumn(), TimeRemainingColumn(),
        console=Console(file=sys.stderr), transient=True,
    ) as progress:
        task = progress.add_task("baking", total=None)

        def update(done: int, total: int) -> None:
            raise_if_interrupted()
            progress.update(task, completed=done, total=total)

        yield update


@click.command()
@click.argument("scene", type=click.Path(dir_okay=False, path_type=Path))
@click.option("-o", "--output", help="Cache to write: .usdc/.usda/.usd, .h5/.hdf5, or 'null' to discard frames.")
@click.option("--dry-run", is_flag=True, help="Print the stage plan and an estimated cost; bake nothing.")
@click.option("--set", "overrides", multiple=True, metavar="KEY=VALUE",
              help="Override a scene or preset key, e.g. --set solver.frequency=600 (repeatable).")
@click.option("--frames", callback=parse_frames, metavar="START:END", help="Bake only these frames (inclusive).")
@click.option("--profile", is_flag=True, help="Print time per solver stage (JIT warm-up apart).")
@click.option("--report", "report_path", type=click.Path(dir_okay=False, path_type=Path),
              help="Write the stats report: .json, or .html with plots.")
@click.option("--json", "as_json", is_flag=True, help="Print the stats report as JSON on stdout.")
@click.option("--compression", type=click.Choice(["gzip", "lzf", "none"]), help="HDF5 compression [scene's, else gzip].")
@click.option("--save-every", type=click.IntRange(min=1), help="USD: save every N frames so memory stays flat [10].")
@click.option("--strict", is_flag=True, help="Treat warnings (mesh repairs when cooking on the fly) as errors.")
@click.option("--force", is_flag=True, help="Run the explicit integrator even beyond its stability limit.")
@click.option("--progress/--no-progress", default=None, help="Progress bar on stderr [on when stderr is a terminal].")
@handle_errors
def bake(scene, output, dry_run, overrides, frames, profile, report_path, as_json, compression, save_every, strict, force, progress):
    """Bake SCENE (a scene .toml) into a cache.

    Exit code 1 on bad input, an unstable bake, a failed write (a full disk) or SIGTERM /
    SIGINT; the whole frames written so far are then kept in NAME.partial.SUFFIX.

    \b
    Examples:
      clothtool bake examples/skirt/scene.toml -o out/skirt.usdc --report out/skirt.json
      clothtool bake examples/skirt/scene.toml -o out/skirt.h5 --set solver.frequency=600 --frames 1:24 --profile
      clothtool bake examples/skirt/scene.toml --dry-run
    """
    from clothtool.bake import BakeOptions
    from clothtool.bake import bake as run_bake
    from clothtool.errors import UnstableError
    from clothtool.io.atomic import check_output_path
    from clothtool.io.cache import NULL_OUTPUTS, supported_suffixes
    from clothtool.errors import FormatError
    from clothtool.report import check_report_path, format_profile_table, format_summary, write_report
    from clothtool.scene.scene import load_scene

    overrides = list(overrides) + (["solver.force=true"] if force else [])
    if dry_run:
        from clothtool.bake import format_plan, plan

        data = plan(load_scene(scene, list(overrides), frames, strict=strict))
        emit_json(data) if as_json else click.echo(format_plan(data))
        return
    if output is None:
        raise click.UsageError("Missing option '-o' / '--output' (or give --dry-run).")
    if output not in NULL_OUTPUTS:
        if Path(output).suffix.lower() not in supported_suffixes():
            raise FormatError(
                f"{output}: unknown cache format '{Path(output).suffix}'; use one of {', '.join(supported_suffixes())} or 'null'"
            )
        check_output_path(output)
    if report_path is not None:
        check_report_path(report_path)
    loaded = load_scene(scene, list(overrides), frames, strict=strict)
    for cloth in loaded.cloths:
        for line in cloth.cook_warnings:
            warn(line)
    show_progress = stderr_is_terminal() if progress is None else progress
    failed = None
    with progress_bar(show_progress) as update:
        try:
            stats = run_bake(loaded, output, BakeOptions(percentiles=True, compression=compression, save_every=save_every, progress=update))
        except UnstableError as exc:
            if getattr(exc, "stats", None) is None:  # refused before the first frame
                raise
            failed = exc
            stats = exc.stats
    report = stats.to_dict()
    if report_path is not None:
        write_report(report, report_path)
    if as_json:
        emit_json(report)
    else:
        click.echo(format_summary(report))
        if profile:
            click.echo(format_profile_table(report))
    if failed is not None:
        raise failed
