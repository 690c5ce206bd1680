"""Scenes from a USD stage: a DCC's shot baked as it is (``clothtool bake shot.usda``).

The stage gives what a TOML scene gives (``formats/scene/usd.md`` documents the names):

* Cloths: ``Mesh`` prims with ``clothtool:role = "cloth"`` (or named with ``--cloth /Path``),
  cooked from the prim with its primvars as paint maps; cook options from
  ``clothtool:cook:<option>`` attributes (``clothtool:cook:preset = "garment"``,
  ``clothtool:cook:max_distance_attr = "maxdist"``, ...), the material from
  ``clothtool:material`` (a preset name) and ``clothtool:material:<field>`` attributes.
  Pinned and max-distance particles attach to the stage's mesh colliders (the body), or to
  the prims ``clothtool:attach`` lists (``"none"``: no attachment).
* Colliders: prims with ``UsdPhysics.CollisionAPI`` or ``clothtool:role = "collider"`` (or
  matching ``--collider PATTERN``); see ``clothtool.scene.usdbodies``.
* Frame range (start/endTimeCode), fps (timeCodesPerSecond), metersPerUnit and upAxis from the
  stage's metadata; the solver preset, pre-roll and output settings from the root layer's
  ``customLayerData["clothtool"]`` (keys ``solver``, ``preroll``, ``output``). Every one of
  them can be overridden with ``--set scene.fps=30`` and the like, like a TOML scene's keys.
"""

from __future__ import annotations

import fnmatch
import hashlib
import re
from pathlib import Path

import numpy as np

from clothtool.errors import ClothtoolError, SceneError
from clothtool.scene.loaders import SceneLoaders
from clothtool.scene.overrides import apply_overrides, check_override_keys
from clothtool.scene.scene import (
    ClothInstance,
    OutputSettings,
    Scene,
    _Context,
    _output_table,
    _scene_table,
    override_schema,
    preroll_of,
)
from clothtool.settings import MotionSettings, Placement, load_material, load_solver

USD_SUFFIXES = (".usd", ".usda", ".usdc", ".usdz")
ROLE_ATTR = "clothtool:role"
COOK_PREFIX = "clothtool:cook:"
MATERIAL_ATTR = "clothtool:material"
MATERIAL_PREFIX = "clothtool:material:"
ATTACH_ATTR = "clothtool:attach"
STAGE_SETTINGS = ("solver", "preroll", "output")
OVERRIDE_SECTIONS = ("scene", "solver", "output")
# the weld keeps vertices within this fraction of the garment's size on one particle
VERTEX_MATCH_TOLERANCE = 1e-4


def is_usd_stage(path: Path) -> bool:
    return Path(path).suffix.lower() in USD_SUFFIXES


def _plain(value):
    """A pxr attribute value as TOML would give it (tables, lists, str, float, int, bool)."""
    if isinstance(value, dict):  # customLayerData's nested dictionaries
        return {str(k): _plain(v) for k, v in value.items()}
    if hasattr(value, "__len__") and not isinstance(value, str):
        return [_plain(v) for v in value]
    if isinstance(value, (bool, int, float, str)):
        return value
    return str(value)


def _prefixed(prim, prefix: str, where: str) -> dict:
    """{name after prefix: value} of the prim's authored attributes under ``prefix``; a
    further namespace is a nested table, as in TOML (``shearing:stiffness`` ->
    ``{"shearing": {"stiffness": ...}}``)."""
    values: dict = {}
    for attr in prim.GetAttributes():
        name = attr.GetName()
        if name.startswith(prefix) and attr.HasAuthoredValue():
            *tables, key = name[len(prefix):].split(":")
            table = values
            for depth, part in enumerate(tables):
                table = table.setdefault(part, {})
                if not isinstance(table, dict):
                    name = ":".join(tables[: depth + 1])
                    raise SceneError(f"{where}: {prefix}{name} is both a value and a namespace; keep one of them")
            if isinstance(table.get(key), dict):
                raise SceneError(f"{where}: {prefix}{':'.join([*tables, key])} is both a value and a namespace; keep one of them")
            table[key] = _plain(attr.Get())
    return values


def _role(prim) -> str | None:
    attr = prim.GetAttribute(ROLE_ATTR)
    return str(attr.Get()) if attr and attr.HasAuthoredValue() else None


def _names(paths: list[str]) -> dict[str, str]:
    """Prim path -> a unique identifier (the prim's name; the whole path where names repeat)."""
    short = [p.rsplit("/", 1)[-1] for p in paths]
    names = {}
    for path, name in zip(paths, short):
        if short.count(name) > 1:
            name = re.sub(r"\W", "_", path.strip("/"))
        names[path] = name
    return names


def _stage_tables(stage, path: Path, frames) -> dict:
    from pxr import UsdGeom

    custom = dict(stage.GetRootLayer().customLayerData.get("clothtool", {}))
    if custom.get("format") == "clothtool-cache":
        raise SceneError(
            f"{path}: is a cache clothtool baked, not a scene; bake takes a scene .toml or a DCC's shot "
            "(a USD stage with a cloth Mesh prim)"
        )
    unknown = [k for k in custom if k not in STAGE_SETTINGS]
    if unknown:
        raise SceneError(f"{path}: customLayerData clothtool key '{unknown[0]}' is unknown; allowed: {', '.join(STAGE_SETTINGS)}")
    scene = {
        "name": path.name.split(".")[0],
        "fps": float(stage.GetTimeCodesPerSecond()),
        "meters_per_unit": float(UsdGeom.GetStageMetersPerUnit(stage)),
        "up_axis": str(UsdGeom.GetStageUpAxis(stage)),
    }
    if stage.HasAuthoredTimeCodeRange():
        start, end = stage.GetStartTimeCode(), stage.GetEndTimeCode()
        if start != int(start) or end != int(end):
            raise SceneError(f"{path}: start/endTimeCode {start:g}..{end:g} are not whole frames; give --frames START:END")
        scene["frames"] = [int(start), int(end)]
    elif frames is None:
        raise SceneError(f"{path}: the stage has no startTimeCode/endTimeCode; author them or give --frames START:END")
    if "preroll" in custom:
        scene["preroll"] = _plain(custom["preroll"])
    tables = {"scene": scene, "solver": _plain(custom.get("solver", "production")), "output": {}}
    if "output" in custom:
        tables["output"] = _plain(dict(custom["output"]))
    return tables


def _schema(cook_keys: tuple[str, ...]) -> dict:
    schema = override_schema(cook_keys)
    return {key: schema[key] for key in OVERRIDE_SECTIONS}


GARMENT_KEEPS_TOPOLOGY = "a garment keeps one topology: export its rest shape without time samples"


def _select(stage, path: Path, cloth_paths, collider_patterns):
    """(cloth prims, collider prims) of the stage."""
    from pxr import UsdGeom, UsdPhysics

    from clothtool.scene.usdbodies import fixed_topology

    prims = list(stage.Traverse())
    if cloth_paths:
        cloths = []
        for text in cloth_paths:
            prim = stage.GetPrimAtPath(text) if text.startswith("/") else None
            if not prim:
                raise SceneError(f"{path}: --cloth {text}: no such prim; give the absolute path of the garment's Mesh prim")
            cloths.append(prim)
    else:
        cloths = [p for p in prims if _role(p) == "cloth"]
    if not cloths:
        raise SceneError(
            f"{path}: no cloth prim found; mark the garment's Mesh with clothtool:role = \"cloth\" or give --cloth /Path/To/Mesh"
        )
    for prim in cloths:
        if not prim.IsA(UsdGeom.Mesh):
            raise SceneError(
                f"{path}: cloth prim {prim.GetPath()} is a {prim.GetTypeName() or 'typeless prim'}, not a Mesh; "
                "mark the garment's Mesh prim instead"
            )
        # the cook reads one rest shape and the output layer overrides points at every frame
        fixed_topology(UsdGeom.Mesh(prim), str(path), GARMENT_KEEPS_TOPOLOGY, points=True)
    cloth_set = {str(p.GetPath()) for p in cloths}
    if collider_patterns:
        colliders = []
        for pattern in collider_patterns:
            matched = [p for p in prims if fnmatch.fnmatchcase(str(p.GetPath()), pattern) and str(p.GetPath()) not in cloth_set]
            if not matched:
                raise SceneError(f"{path}: --collider {pattern}: matches no prim; give a prim path or pattern such as '/Shot/Body*'")
            colliders += [p for p in matched if p not in colliders]
    else:
        colliders = [
            p for p in prims
            if str(p.GetPath()) not in cloth_set and (p.HasAPI(UsdPhysics.CollisionAPI) or _role(p) == "collider")
        ]
    return cloths, colliders


def _cook(loaders: SceneLoaders, source: Path, prim, options_table: dict, mpu: float, up_axis: str, strict: bool):
    """(mesh, fabric, cook warnings) of the cloth ``prim`` of the stage in ``source``."""
    where = f"{source}: prim {prim.GetPath()}"
    table = dict(options_table)
    if "preset" in table:
        table["preset"] = str(table["preset"])
    fixed = {"strict": strict, "meters_per_unit": mpu, "up_axis": up_axis}
    options = loaders.cook_options(table, f"{where} {COOK_PREFIX}*", fixed)
    mesh = loaders.read_mesh(source, str(prim.GetPath()))
    fabric, warnings = loaders.cook(mesh, options, hashlib.sha256(source.read_bytes()).hexdigest())
    return mesh, fabric, warnings


def vertex_particles(mesh_points: np.ndarray, particle_points: np.ndarray, where: str) -> np.ndarray:
    """i32 (v,): per mesh vertex the particle the cook welded it into (nearest rest position)."""
    from scipy.spatial import cKDTree

    distance, index = cKDTree(particle_points).query(mesh_points)
    size = float(np.ptp(particle_points, axis=0).max()) or 1.0
    if distance.size and distance.max() > VERTEX_MATCH_TOLERANCE * size:
        raise SceneError(f"{where}: vertex {int(np.argmax(distance))} has no particle; the cook moved it, re-cook without repairs")
    return index.astype(np.int32)


def _attach(prim, collider_names: dict[str, str], mesh_colliders: list[str], where: str) -> tuple[str, ...]:
    attr = prim.GetAttribute(ATTACH_ATTR)
    if not attr or not attr.HasAuthoredValue():
        return tuple(collider_names[p] for p in mesh_colliders)
    value = _plain(attr.Get())
    targets = [value] if isinstance(value, str) else list(value)
    if targets == ["none"]:
        return ()
    for target in targets:
        if target not in mesh_colliders:
            raise SceneError(
                f"{where}: {ATTACH_ATTR} names {target!r}, which is not a mesh collider; mesh colliders: "
                f"{', '.join(mesh_colliders) or 'none'} (or \"none\")"
            )
    return tuple(collider_names[t] for t in targets)


def _cloth(ctx, stage_path: Path, prim, name, mpu, up_axis, strict, collider_names, mesh_colliders) -> ClothInstance:
    where = f"{stage_path}: prim {prim.GetPath()}"
    try:
        mesh, fabric, warnings = _cook(ctx.loaders, stage_path, prim, _prefixed(prim, COOK_PREFIX, where), mpu, up_axis, strict)
    except ClothtoolError as exc:
        text = str(exc)
        raise SceneError(text if text.startswith(str(stage_path)) else f"{where}: {text}") from None
    material_table = {"preset": str(prim.GetAttribute(MATERIAL_ATTR).Get())} if prim.GetAttribute(MATERIAL_ATTR) else {}
    material_table.setdefault("preset", "cotton")
    material_table.update(_prefixed(prim, MATERIAL_PREFIX, where))
    try:
        material = load_material(material_table, f"{where} {MATERIAL_PREFIX}*")
    except ClothtoolError as exc:
        raise SceneError(f"{where}: {exc}") from None
    # the bake writes points in the cooked mesh's vertex order (Fabric.in_vertex_order): map to that
    mapping = vertex_particles(mesh.vertex_pos, fabric.in_vertex_order(fabric.rest_pos).astype(np.float64), where)
    return ClothInstance(
        name=name, source=f"{stage_path.name}:{prim.GetPath()}", fabric=fabric, material=material, placement=Placement(),
        track=None, motion=MotionSettings(), backstop=None, initial_velocity=np.zeros(3),
        cook_warnings=warnings, attach=_attach(prim, collider_names, mesh_colliders, where),
        prim=str(prim.GetPath()), vertex_particle=mapping,
    )


def read_usd_scene(
    path: str | Path,
    loaders: SceneLoaders,
    overrides: list[str] = (),
    frames: tuple[int, int] | None = None,
    strict: bool = False,
    cloth: tuple[str, ...] = (),
    collider: tuple[str, ...] = (),
) -> Scene:
    """The Scene of a USD stage (see module docstring), its cloths cooked by ``loaders``
    (``clothtool.loading.load_usd_scene`` passes the cook's); ``cloth`` prim paths and
    ``collider`` patterns replace the marked prims."""
    from clothtool.scene.colliders import SceneColliders
    from clothtool.scene.usdbodies import (
        body_collider,
        open_stage,
        shot_clock,
        skinning_targets,
        stage_units,
        unit_root,
        with_preroll,
    )

    path = Path(path)
    if not path.is_file():
        raise SceneError(f"{path}: scene file not found; check the path")
    stage = open_stage(path)
    raw = _stage_tables(stage, path, frames)
    check_override_keys(raw, list(overrides), _schema(loaders.cook_keys))
    tables = apply_overrides(raw, list(overrides))
    ctx = _Context(path, loaders)
    name, fps, start, end, mpu, up_axis, gravity = _scene_table(ctx, tables["scene"], frames, path.stem)
    preroll = preroll_of(ctx, tables["scene"])
    try:
        solver = load_solver(tables["solver"], f"{path}: [solver]")
    except ClothtoolError as exc:
        raise SceneError(f"{path}: [solver] {exc}") from None
    output: OutputSettings = _output_table(ctx, tables["output"])

    cloth_prims, collider_prims = _select(stage, path, list(cloth), list(collider))
    clock = shot_clock(stage, fps, start, end)
    skinned = skinning_targets(stage, str(path))
    collider_paths = [str(p.GetPath()) for p in collider_prims]
    collider_names = _names(collider_paths)
    units = stage_units(stage, str(path))
    bodies = []
    for prim in collider_prims:
        body = body_collider(prim, collider_names[str(prim.GetPath())], clock, skinned.get(str(prim.GetPath())), str(path),
                             unit_root(prim, units, str(path)))
        bodies.append(with_preroll(body, clock, fps, start, preroll))
    mesh_colliders = [p for p, body in zip(collider_paths, bodies) if body.kind == "mesh"]
    cloth_paths = [str(p.GetPath()) for p in cloth_prims]
    cloth_names = _names(cloth_paths)
    cloths = tuple(
        _cloth(ctx, path, prim, cloth_names[str(prim.GetPath())], mpu, up_axis, strict, collider_names, mesh_colliders)
        for prim in cloth_prims
    )
    colliders = SceneColliders(tuple(bodies)) if bodies else None
    return Scene(name, path, fps, start, end, mpu, up_axis, gravity, solver, cloths, None, {}, output, colliders, preroll)
