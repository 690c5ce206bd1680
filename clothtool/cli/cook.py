"""``clothtool cook``: a garment mesh into a fabric file."""

from __future__ import annotations

import dataclasses
import hashlib
from pathlib import Path

import click

from clothtool.cli.batch import batch_options, is_batch, progress_option, run_cook_batch
from clothtool.cli.common import emit_json, float_list, handle_errors, warn


@click.command()
@click.argument("meshes", metavar="MESH...", nargs=-1, required=True, type=click.Path(dir_okay=False, path_type=Path))
@click.option("-o", "--output", type=click.Path(dir_okay=False, path_type=Path), required=True,
              help="Fabric file to write (.fabric.h5); for several meshes a template such as 'out/{name}.fabric.h5'.")
@click.option("--preset", help="Cook preset: a bundled name (garment, coarse) or a .toml path; options below override it.")
@click.option("--prim", help="USD input: path of the UsdGeom.Mesh prim (default: the first mesh).")
@click.option("--weld", type=float, help="Weld vertices closer than this fraction of the bounding-box diagonal [1e-6].")
@click.option("--meters-per-unit", type=float, help="Size of one mesh unit in metres [the file's, else 1].")
@click.option("--up-axis", type=click.Choice(["Y", "Z"]), help="Up axis of the mesh [the file's, else Y].")
@click.option("--hang-direction", callback=float_list(3), help="X,Y,Z direction that separates vertical from horizontal stretch [minus the up axis].")
@click.option("--recover-quads/--no-recover-quads", default=None, help="Pair triangles into quads so both diagonals become shear constraints [on].")
@click.option("--shearing/--no-shearing", default=None, help="Build the shearing phase [on].")
@click.option("--bending/--no-bending", default=None, help="Build the bending phase [on].")
@click.option("--tethers", type=click.Choice(["auto", "geodesic", "euclidean", "none"]), help="Tether lengths over the mesh or straight [auto: geodesic when pinned].")
@click.option("--tether-anchors", type=int, help="Tethers per particle, to the nearest pinned islands [1].")
@click.option("--pin-attr", help="Pin particles whose painted weight in this vertex attribute reaches --pin-threshold.")
@click.option("--pin-threshold", type=float, help="Pin weight at which a particle is pinned [0.5].")
@click.option("--pin-box", callback=float_list(6), help="Pin particles inside XMIN,YMIN,ZMIN,XMAX,YMAX,ZMAX (mesh units).")
@click.option("--pin-file", type=click.Path(path_type=Path), help="Pin the file vertices listed (0-based indices) in this text file.")
@click.option("--max-distance-attr", help="Vertex attribute (0..1) painting the motion-constraint radius.")
@click.option("--max-distance-range", callback=float_list(2), help="LOW,HIGH radius for weights 0 and 1 (mesh units) [0,1].")
@click.option("--stiffness-attr", help="Vertex attribute (0..1) scaling constraint stiffness.")
@click.option("--virtual-particles", type=int, help="Virtual collision particles per triangle: 0, 1, 3 or 4 [0].")
@click.option("--reorder/--no-reorder", default=None,
              help="Renumber particles for memory locality (caches keep the mesh's vertex order) [on].")
@click.option("--strict", is_flag=True, help="Treat repairs and warnings as errors.")
@click.option("--json", "as_json", is_flag=True, help="Print the fabric summary (batch: the manifest) as JSON.")
@batch_options
@progress_option
@handle_errors
def cook(meshes, output: Path, preset, prim, strict, as_json, jobs_n, scheduler, manifest, resume, progress,
         **overrides) -> None:
    """Cook MESH (OBJ, PLY, glTF/GLB, OFF, STL or USD) into a fabric file.

    Several meshes or globs with an output template cook as a batch (see --jobs).

    \b
    Examples:
      clothtool cook examples/skirt/skirt.obj --preset garment -o skirt.fabric.h5
      clothtool cook 'garments/*.obj' --preset garment -o 'out/{name}.fabric.h5' --jobs 2
    """
    if is_batch(meshes, output, jobs_n=jobs_n, scheduler=scheduler, manifest=manifest):
        overrides = {k: (str(v) if isinstance(v, Path) else v) for k, v in overrides.items() if v is not None}
        run_cook_batch(meshes, output, preset, prim, strict, overrides, as_json, jobs_n, scheduler, manifest, resume, progress)
        return
    mesh = meshes[0]
    from clothtool.cook.cooker import CookOptions, cook_fabric
    from clothtool.inputs import recording_inputs, refuse_output_onto_input
    from clothtool.io.atomic import check_output_path
    from clothtool.io.fabric_file import check_fabric_output_name, write_fabric
    from clothtool.io.meshin import read_mesh
    from clothtool.presets import apply_mapping, load_preset
    from clothtool.summary import fabric_summary, format_fabric_summary

    check_fabric_output_name(output)
    check_output_path(output)
    with recording_inputs() as inputs:
        options = CookOptions()
        if preset:
            mapping, label = load_preset("cook", preset)
            options = apply_mapping(options, mapping, label, skip=("strict",))
        given = {k: (str(v) if isinstance(v, Path) else v) for k, v in overrides.items() if v is not None}
        options = dataclasses.replace(options, **given, strict=strict)

        cloth_mesh = read_mesh(mesh, prim=prim)
        digest = hashlib.sha256(mesh.read_bytes()).hexdigest()
        result = cook_fabric(cloth_mesh, options, source_sha256=digest)
    refuse_output_onto_input(output, inputs)
    for line in result.warnings:
        warn(line)
    write_fabric(result.fabric, output)

    summary = fabric_summary(result.fabric)
    summary["welded_vertices"] = result.welded_vertices
    summary["warnings"] = result.warnings
    if as_json:
        emit_json(summary)
    else:
        click.echo(format_fabric_summary(summary, output.name))
        if result.welded_vertices:
            click.echo(f"  welded     {result.welded_vertices} coincident vertices")
