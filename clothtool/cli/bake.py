"""``clothtool bake``: simulate a scene into an HDF5 or USD cache."""

from __future__ import annotations

from pathlib import Path

import click

from clothtool.cli.batch import batch_options, is_batch, run_bake_batch, wedge_options
from clothtool.cli.common import emit_json, handle_errors, raise_if_interrupted, warn
from clothtool.cli.progress import bake_progress


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


def cache_output(loaded, output: str, standalone: bool, save_every: int | None = None):
    """``output``, or a layer-over-shot writer for a USD stage baked into a USD file."""
    from clothtool.scene.usdstage import is_usd_stage

    if standalone or not is_usd_stage(loaded.path) or not is_usd_stage(Path(output)):
        return output
    from clothtool.io.cache import CacheOptions
    from clothtool.io.usdshot import ShotLayerWriter

    return ShotLayerWriter(Path(output), loaded, CacheOptions(save_every=save_every or loaded.output.save_every))


@click.command()
@click.argument("scenes", metavar="SCENE...", nargs=-1, required=True, type=click.Path(dir_okay=False, path_type=Path))
@click.option("-o", "--output", help="Cache to write: .usdc/.usda/.usd, .h5/.hdf5, or 'null' to discard frames; "
              "for several scenes or wedges a template such as 'caches/{scene}/{wedge}.usdc'.")
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
@click.option("--force", is_flag=True, help="Bake anyway: beyond the workload limits (iterations per frame, frames, disk space) and the explicit integrator's stability limit.")
@click.option("--cloth", multiple=True, metavar="/PRIM",
              help="USD stage: bake this Mesh prim as cloth (repeatable) [prims with clothtool:role = \"cloth\"].")
@click.option("--collider", multiple=True, metavar="PATTERN",
              help="USD stage: collide with prims whose path matches (repeatable) [prims with UsdPhysics.CollisionAPI].")
@click.option("--standalone", is_flag=True,
              help="USD stage to USD cache: write a plain cache, not a layer over the shot.")
@click.option("--progress/--no-progress", default=None, help="Progress on stderr: a bar on a terminal, else a line every CLOTHTOOL_PROGRESS_INTERVAL s [10] (default: bar only on a terminal).")
@wedge_options
@batch_options
@handle_errors
def bake(scenes, output, dry_run, overrides, frames, profile, report_path, as_json, compression, save_every, strict, force,
         cloth, collider, standalone, progress, wedges, wedge_zips, jobs_n, scheduler, manifest, resume):
    """Bake SCENE (a scene .toml, or a USD stage: a DCC's shot) into a cache.

    From a USD stage into a USD file the cache is a layer that sublayers the shot and
    overrides the garments' points, so a DCC opens one file with the body and the cloth
    (--standalone writes the plain cache instead).

    Several scenes or globs, --wedge, or an output template bake as a batch (see --jobs).

    Exit code 1 on bad input, an unstable bake, a failed write (a full disk) or SIGTERM /
    SIGINT; the whole frames written so far are then kept in NAME.partial.SUFFIX.

    \b
    Examples:
      clothtool bake examples/skirt/scene.toml -o out/skirt.usdc --report out/skirt.json
      clothtool bake examples/skirt/scene.toml -o out/skirt.h5 --set solver.frequency=600 --frames 1:24 --profile
      clothtool bake examples/skirt/scene.toml --dry-run
      clothtool bake 'shots/*.toml' -o 'caches/{scene}/{wedge}.usdc' --wedge solver.frequency=300,600 --jobs 2
      clothtool bake examples/shot/shot.usda -o out/shot_cloth.usda
    """
    if is_batch(scenes, output, jobs_n=jobs_n, scheduler=scheduler, manifest=manifest, wedges=wedges, wedge_zips=wedge_zips):
        run_bake_batch(scenes, output, list(overrides) + (["solver.force=true"] if force else []), frames, strict, wedges,
                       wedge_zips, as_json, jobs_n, scheduler, manifest, resume, progress, dry_run=dry_run,
                       report_path=report_path, profile=profile, compression=compression, save_every=save_every)
        return
    scene = scenes[0]
    from clothtool.bake import BakeOptions
    from clothtool.bake import bake as run_bake
    from clothtool.errors import UnstableError
    from clothtool.preflight import load_for_bake
    from clothtool.report import format_profile_table, format_summary, write_report

    overrides = list(overrides) + (["solver.force=true"] if force else [])
    if dry_run:
        from clothtool.bake import format_plan, plan

        # the checks of a bake into "null": no output to refuse, the same workload limits
        data = plan(load_for_bake(scene, "null", overrides, frames, strict, cloth=cloth, collider=collider))
        emit_json(data) if as_json else click.echo(format_plan(data))
        return
    if output is None:
        raise click.UsageError("Missing option '-o' / '--output' (or give --dry-run).")
    loaded = load_for_bake(scene, output, overrides, frames, strict, report_path, cloth=cloth, collider=collider)
    for cloth in loaded.cloths:
        for line in cloth.cook_warnings:
            warn(line)
    failed = None
    with bake_progress(progress, f"bake {scene.name}") as show:

        def update(done: int, total: int) -> None:
            raise_if_interrupted()  # once per frame: a signal that landed in a destructor still ends the bake
            if show is not None:
                show(done, total)

        try:
            stats = run_bake(loaded, cache_output(loaded, output, standalone, save_every), BakeOptions(percentiles=True, penetration=True, compression=compression, save_every=save_every, progress=update, profile_stages=profile))
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
