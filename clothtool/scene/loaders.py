"""What the scene readers read and cook the files a scene names with.

A scene names meshes (cloths cooked as the scene loads, mesh colliders) and fabrics. Reading
those files is io's job and cooking the cook's, and DESIGN.md's one-way imports keep the scene
layer from importing either. The scene readers therefore take a ``SceneLoaders`` from the
layer above: ``clothtool.loading`` fills it with io's readers and the cook (and its
``load_scene`` is the entry point callers use).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:  # pragma: no cover
    from clothtool.fabric import Fabric
    from clothtool.mesh import ClothMesh


@dataclasses.dataclass(frozen=True)
class SceneLoaders:
    """Attributes:

    read_mesh: ``(path, prim)`` -> the ClothMesh of a mesh file (``prim``: a USD Mesh prim's
        path, or None). Raises a ClothtoolError naming the file.
    read_fabric: ``path`` -> the Fabric of a cooked fabric file.
    cook_options: ``(table, label, fixed)`` -> the cook's options from a scene's cook table
        (``preset`` and option keys; ``label`` names the table in errors) with the ``fixed``
        fields (``strict``, ``meters_per_unit``, ...) set over it. Opaque to the scene.
    cook: ``(mesh, options, digest)`` -> ``(fabric, warnings)``, cooking ``mesh`` with
        ``options``; ``digest`` is the SHA-256 of the mesh file, recorded in the fabric.
    cook_keys: the names of the cook options (what ``--set cloth.NAME.cook.KEY`` may name).
    mesh_suffixes: file suffixes ``read_mesh`` reads.
    """

    read_mesh: Callable[[Path, str | None], ClothMesh]
    read_fabric: Callable[[Path], Fabric]
    cook_options: Callable[[dict, str, dict], Any]
    cook: Callable[[ClothMesh, Any, str], tuple[Fabric, tuple[str, ...]]]
    cook_keys: tuple[str, ...]
    mesh_suffixes: tuple[str, ...]
