"""``clothtool bake``: simulate a scene into an HDF5 or USD cache."""

from __future__ import annotations

import contextlib
import sys
from pathlib import Path

import click

from clothtool.cli.common import emit_json, handle_errors, stderr_is_terminal, warn


def parse_frames(ctx, param, value):
    if value is None:
        return None
    try:
        start, end = (int(v) for v in value.split(":"))
    except ValueError:
        raise click.BadParameter(f"'{value}' is not START:END with integer frame numbers, e.g. 1:48") from None
    if end < start:
        raise click.BadParameter(f"'{value}' runs backwards; give START:END with END >= START")
    return start, end


@contextlib.contextmanager
def progress_bar(enabled: bool):
    """A rich progress bar on stderr when it is a terminal; yields a progress callback."""
    if not enabled:
        yield None
        return
    from rich.console import Console
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TimeRemainingColumn

    with Progress(
        "[progress.description]{task.description}", BarColumn(), MofNCompleteColumn(), TimeRemainingColumn(),
        console=Console(file=sys.stderr), transient=True,
    ) as progress:
        task = progress.add_task("baking", total=None)

        def update(done: int, total: int) -> None:
            progress.update(task, completed=done, total=total)

        yield update


def refuse_outputs_onto_inputs(output: str, report_path: Path | None, inputs) -> None:
    """The cache (and its partial name, kept if the bake fails) and the report must not be
    any file the scene read."""
    from clothtool.inputs import refuse_output_onto_input
    from clothtool.io.cache import NULL_OUTPUTS, partial_path

    if output not in NULL_OUTPUTS:
        refuse_output_onto_input(output, inputs, "cache")
        refuse_output_onto_input(partial_path(output), inputs, "partial cache a failed bake keeps")
    if report_path is not None:
        refuse_output_onto_input(report_path, inputs, "report")


def load_any_scene(scene: Path, overrides: list[str], frames, strict: bool, cloth, collider):
    """A TOML scene, or a USD stage (a DCC's shot) by its suffix."""
    from clothtool.scene.usdstage import is_usd_stage, load_usd_scene

    if is_usd_stage(scene):
        return load_usd_scene(scene, overrides, frames, strict=strict, cloth=tuple(cloth), collider=tuple(collider))
    if cloth or collider:
        raise click.UsageError("--cloth and --collider pick prims of a USD stage; SCENE is a TOML scene")
    from clothtool.scene.scene import load_scene

    return load_scene(scene, overrides, frames, strict=strict)


def cache_output(loaded, output: str, standalone: bool, save_every: int | None = None):
    """``output``, or a layer-over-shot writer for a USD stage baked into a USD file."""
    from clothtool.scene.usdstage import is_usd_stage

    if standalone or not is_usd_stage(loaded.path) or not is_usd_stage(Path(output)):
        return output
    from clothtool.io.cache import CacheOptions
    from clothtool.io.usdshot import ShotLayerWriter

    return ShotLayerWriter(Path(output), loaded, CacheOptions(save_every=save_every or loaded.output.save_every))


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
@click.option("--cloth", multiple=True, metavar="/PRIM",
              help="USD stage: bake this Mesh prim as cloth (repeatable) [prims with clothtool:role = \"cloth\"].")
@click.option("--collider", multiple=True, metavar="PATTERN",
              help="USD stage: collide with prims whose path matches (repeatable) [prims with UsdPhysics.CollisionAPI].")
@click.option("--standalone", is_flag=True,
              help="USD stage to USD cache: write a plain cache, not a layer over the shot.")
@click.option("--progress/--no-progress", default=None, help="Progress bar on stderr [on when stderr is a terminal].")
@handle_errors
def bake(scene, output, dry_run, overrides, frames, profile, report_path, as_json, compression, save_every, strict, force,
         cloth, collider, standalone, progress):
    """Bake SCENE (a scene .toml, or a USD stage: a DCC's shot) into a cache.

    From a USD stage into a USD file the cache is a layer that sublayers the shot and
    overrides the garments' points, so a DCC opens one file with the body and the cloth
    (--standalone writes the plain cache instead).

    Exit code 1 on bad input or an unstable bake (the frames written so far are kept in
    NAME.partial.SUFFIX).

    \b
    Examples:
      clothtool bake examples/skirt/scene.toml -o out/skirt.usdc --report out/skirt.json
      clothtool bake examples/skirt/scene.toml -o out/skirt.h5 --set solver.frequency=600 --frames 1:24 --profile
      clothtool bake examples/skirt/scene.toml --dry-run
      clothtool bake examples/shot/shot.usda -o out/shot_cloth.usda
    """
    from clothtool.bake import BakeOptions
    from clothtool.bake import bake as run_bake
    from clothtool.errors import UnstableError
    from clothtool.inputs import recording_inputs
    from clothtool.io.cache import check_cache_output_name
    from clothtool.report import check_report_path, format_profile_table, format_summary, write_report
    from clothtool.workload import check_workload

    overrides = list(overrides) + (["solver.force=true"] if force else [])
    if dry_run:
        from clothtool.bake import format_plan, plan

        loaded = load_any_scene(scene, list(overrides), frames, strict, cloth, collider)
        check_workload(loaded, None, loaded.solver.force)
        data = plan(loaded)
        emit_json(data) if as_json else click.echo(format_plan(data))
        return
    if output is None:
        raise click.UsageError("Missing option '-o' / '--output' (or give --dry-run).")
    check_cache_output_name(output)
    if report_path is not None:
        check_report_path(report_path)
    with recording_inputs() as inputs:
        loaded = load_any_scene(scene, list(overrides), frames, strict, cloth, collider)
    refuse_outputs_onto_inputs(output, report_path, inputs)
    check_workload(loaded, output, loaded.solver.force)
    for cloth in loaded.cloths:
        for line in cloth.cook_warnings:
            warn(line)
    show_progress = stderr_is_terminal() if progress is None else progress
    failed = None
    with progress_bar(show_progress) as update:
        try:
            stats = run_bake(loaded, cache_output(loaded, output, standalone, save_every), BakeOptions(percentiles=True, compression=compression, save_every=save_every, progress=update))
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
