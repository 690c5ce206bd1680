"""Loading scenes: the scene readers with io's file readers and the cook plugged in.

DESIGN.md's imports flow one way, and the scene layer imports neither io nor the cook; this
module sits above all three (with the bake) and hands the scene readers a ``SceneLoaders``
(``clothtool.scene.loaders``) made of io's mesh and fabric readers and the cook. Its
``load_scene``, ``load_usd_scene`` and ``load_any_scene`` are the entry points the CLI, the
bake's callers, the tests and the benchmarks use. The cook and io's readers are imported when
the first scene loads (the cook brings numba), not when this module is imported.
"""

from __future__ import annotations

import dataclasses
import functools
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from clothtool.errors import UsageError
from clothtool.presets import apply_mapping, load_preset
from clothtool.scene.loaders import SceneLoaders
from clothtool.scene.scene import Scene, read_scene
from clothtool.scene.usdstage import is_usd_stage, read_usd_scene

if TYPE_CHECKING:  # pragma: no cover
    from clothtool.cook.cooker import CookOptions
    from clothtool.fabric import Fabric
    from clothtool.mesh import ClothMesh


def _cook_options(table: dict, label: str, fixed: dict) -> CookOptions:
    """The cook's options from a scene's cook table: its ``preset`` first, then its keys
    (checked and typed, errors naming ``label``), then the ``fixed`` fields."""
    from clothtool.cook.cooker import CookOptions

    table = dict(table)
    options = CookOptions()
    preset = table.pop("preset", None)
    if preset is not None:
        mapping, preset_label = load_preset("cook", preset)
        options = apply_mapping(options, mapping, preset_label)
    options = apply_mapping(options, table, label)
    return dataclasses.replace(options, **fixed)


def _cook(mesh: ClothMesh, options: CookOptions, digest: str) -> tuple[Fabric, tuple[str, ...]]:
    from clothtool.cook.cooker import cook_fabric

    result = cook_fabric(mesh, options, digest)
    return result.fabric, tuple(result.warnings)


@functools.cache
def scene_loaders() -> SceneLoaders:
    """The loaders every scene read through this module uses."""
    from clothtool.cook.cooker import CookOptions
    from clothtool.io.fabric_file import read_fabric
    from clothtool.io.meshin import SUPPORTED_SUFFIXES, read_mesh

    return SceneLoaders(
        read_mesh=read_mesh,
        read_fabric=read_fabric,
        cook_options=_cook_options,
        cook=_cook,
        cook_keys=tuple(field.name for field in dataclasses.fields(CookOptions)),
        mesh_suffixes=tuple(SUPPORTED_SUFFIXES),
    )


def load_scene(
    path: str | Path, overrides: Sequence[str] = (), frames: tuple[int, int] | None = None, strict: bool = False
) -> Scene:
    """Read and validate a TOML scene (``clothtool.scene.scene``); ``strict`` makes mesh
    repairs of cloths cooked on the fly errors."""
    return read_scene(path, scene_loaders(), list(overrides), frames, strict)


def load_usd_scene(
    path: str | Path,
    overrides: Sequence[str] = (),
    frames: tuple[int, int] | None = None,
    strict: bool = False,
    cloth: tuple[str, ...] = (),
    collider: tuple[str, ...] = (),
) -> Scene:
    """The Scene of a USD stage (``clothtool.scene.usdstage``); ``cloth`` prim paths and
    ``collider`` patterns replace the marked prims."""
    return read_usd_scene(path, scene_loaders(), list(overrides), frames, strict=strict, cloth=tuple(cloth), collider=tuple(collider))


def load_any_scene(
    path: str | Path,
    overrides: Sequence[str] = (),
    frames: tuple[int, int] | None = None,
    strict: bool = False,
    cloth: tuple[str, ...] = (),
    collider: tuple[str, ...] = (),
) -> Scene:
    """A TOML scene, or a USD stage (a DCC's shot), by the file's suffix; ``cloth`` and
    ``collider`` pick prims of a stage only."""
    if is_usd_stage(Path(path)):
        return load_usd_scene(path, overrides, frames, strict=strict, cloth=tuple(cloth), collider=tuple(collider))
    if cloth or collider:
        raise UsageError(f"{path}: --cloth and --collider pick prims of a USD stage, and this scene is a TOML file")
    return load_scene(path, list(overrides), frames, strict=strict)
