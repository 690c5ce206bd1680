"""Everything a bake checks before its first frame, in one place for the command line and
for batches: the output can be written, the scene loads, no output lands on a file the scene
read, and the workload is one a user can have meant."""

from __future__ import annotations

import os
from pathlib import Path

from clothtool.inputs import recording_inputs, refuse_output_onto_input
from clothtool.io.cache import NULL_OUTPUTS, check_cache_output_name, partial_path
from clothtool.loading import load_any_scene
from clothtool.scene.scene import Scene
from clothtool.workload import check_workload


def load_for_bake(
    scene_path: str | os.PathLike,
    output: str | os.PathLike,
    overrides: list[str] = (),
    frames: tuple[int, int] | None = None,
    strict: bool = False,
    report_path: str | os.PathLike | None = None,
    cloth: tuple[str, ...] = (),
    collider: tuple[str, ...] = (),
) -> Scene:
    """The scene at ``scene_path`` (TOML, or a USD stage with ``cloth``/``collider`` picks),
    loaded and checked for a bake into ``output`` (a cache
    path or "null") with an optional report. Raises UsageError (an output it cannot write or
    one that is an input) or SceneError (bad scene, absurd workload)."""
    from clothtool.report import check_report_path

    check_cache_output_name(output)
    if report_path is not None:
        check_report_path(report_path)
    with recording_inputs() as inputs:
        scene = load_any_scene(scene_path, list(overrides), frames, strict, cloth, collider)
    if str(output) not in NULL_OUTPUTS:
        refuse_output_onto_input(output, inputs, "cache")
        refuse_output_onto_input(partial_path(output), inputs, "partial cache a failed bake keeps")
    if report_path is not None:
        refuse_output_onto_input(Path(report_path), inputs, "report")
    check_workload(scene, output, scene.solver.force)
    return scene
