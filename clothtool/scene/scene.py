"""Scenes: a versioned TOML file (``formats/scene/v1.md``) turned into a validated Scene.

``read_scene(path, loaders, overrides)`` reads the TOML, applies ``--set`` overrides to the
raw tables, checks every key (unknown keys are errors that list the allowed ones), resolves
paths relative to the scene file, loads or cooks each cloth's fabric and loads the presets.
Mesh and fabric files are read, and meshes cooked, by the ``loaders``
(``clothtool.scene.loaders``); ``clothtool.loading.load_scene`` passes io's and the cook's.
"""

from __future__ import annotations

import dataclasses
import hashlib
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from clothtool.errors import ClothtoolError, SceneError
from clothtool.fabric import Fabric
from clothtool.presets import read_toml
from clothtool.scene.loaders import SceneLoaders
from clothtool.scene.overrides import Named, apply_overrides, check_override_keys
from clothtool.scene.trackload import TRACK_KEYS, load_track
from clothtool.scene.tracks import Track, euler_xyz_to_quat, quat_to_matrix
from clothtool.settings import BackstopSettings, Material, MotionSettings, Placement, SolverConfig, load_material, load_solver

if TYPE_CHECKING:  # pragma: no cover
    from clothtool.scene.colliders import SceneColliders

FORMAT_VERSION = 1
TOP_LEVEL_KEYS = ("version", "scene", "solver", "output", "wind", "track", "cloth", "collider")
SCENE_KEYS = ("name", "fps", "frames", "meters_per_unit", "up_axis", "gravity", "preroll")
OUTPUT_KEYS = ("attributes", "compression", "save_every")
OUTPUT_ATTRIBUTES = ("velocities", "rest", "stats", "colliders")
WIND_KEYS = ("velocity", "track", "fluid_density")
CLOTH_KEYS = (
    "fabric", "mesh", "cook", "material", "translate", "rotate", "rotate_euler", "scale",
    "track", "motion", "backstop", "initial_velocity", "attach",
)
STANDARD_GRAVITY = 9.81
MAX_FPS = 10_000.0  # beyond it a "frame rate" is a typo (and iteration lengths underflow)
COMPRESSIONS = ("gzip", "lzf", "none")


@dataclasses.dataclass(frozen=True, eq=False)
class ClothInstance:
    name: str
    source: str  # the fabric or mesh path as the scene gives it
    fabric: Fabric
    material: Material
    placement: Placement
    track: Track | None
    motion: MotionSettings
    backstop: BackstopSettings | None
    initial_velocity: np.ndarray
    cook_warnings: tuple[str, ...] = ()
    # pinned and max-distance particles follow these mesh colliders (clothtool.solver.attach)
    attach: tuple[str, ...] = ()
    # a cloth read from a USD stage: its Mesh prim, and per mesh vertex the particle it became
    prim: str | None = None
    vertex_particle: np.ndarray | None = None


@dataclasses.dataclass(frozen=True)
class OutputSettings:
    attributes: frozenset[str] = frozenset({"velocities"})
    compression: str = "gzip"
    save_every: int = 10


@dataclasses.dataclass(frozen=True, eq=False)
class WindSettings:
    velocity: np.ndarray  # (3,) constant velocity, scene units/s (added to the track's)
    track: Track | None  # its translation channel is a velocity in scene units/s
    fluid_density: float = 1.2

    def velocity_at(self, time: float) -> np.ndarray:
        velocity = self.velocity
        if self.track is not None:
            velocity = velocity + self.track.sample(time).translation
        return velocity


@dataclasses.dataclass(frozen=True, eq=False)
class Scene:
    name: str
    path: Path
    fps: float
    start_frame: int
    end_frame: int
    meters_per_unit: float
    up_axis: str
    gravity: np.ndarray
    solver: SolverConfig
    cloths: tuple[ClothInstance, ...]
    wind: WindSettings | None
    tracks: dict[str, Track]
    output: OutputSettings
    colliders: "SceneColliders | None" = None
    preroll: int = 0  # frames simulated before start_frame (not written) so the cloth settles

    @property
    def frame_count(self) -> int:
        return self.end_frame - self.start_frame + 1

    def frame_time(self, frame: int) -> float:
        """Seconds at ``frame`` (frame f happens at f / fps)."""
        return frame / self.fps


class _Context:
    """Error messages name the scene file and the table/key; ``loaders`` read the files the
    scene names."""

    def __init__(self, path: Path, loaders: SceneLoaders):
        self.path = path
        self.base = path.parent
        self.loaders = loaders

    def fail(self, where: str, message: str):
        raise SceneError(f"{self.path}: [{where}] {message}")

    def check_keys(self, table, allowed, where: str) -> dict:
        if not isinstance(table, dict):
            self.fail(where, f"must be a table, got {table!r}")
        unknown = [k for k in table if k not in allowed]
        if unknown:
            self.fail(where, f"unknown key '{unknown[0]}'; allowed keys: {', '.join(allowed)}")
        return table

    def number(self, table, key, where, default=None, positive=False):
        value = table.get(key, default)
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not np.isfinite(value):
            self.fail(where, f"key '{key}' must be a number, got {value!r}")
        if positive and not value > 0:
            self.fail(where, f"key '{key}' = {value!r} must be positive")
        return float(value)

    def track(self, table, where: str, tracks: dict[str, Track]) -> Track | None:
        """The track that ``table``'s 'track' key names, or None without one."""
        if "track" not in table:
            return None
        name = table["track"]
        known = f"tracks: {', '.join(tracks) or 'none'}"
        if not isinstance(name, str):
            self.fail(where, f"key 'track' = {name!r} must be the name of a [track.NAME] table; {known}")
        if name not in tracks:
            self.fail(where, f"key 'track' = {name!r}: the scene has no [track.{name}]; {known}")
        return tracks[name]

    def vector(self, table, key, where, size=3, default=None):
        value = table.get(key, default)
        try:
            array = np.asarray(value, np.float64)
        except (TypeError, ValueError):
            array = np.zeros(0)
        if array.shape != (size,) or not np.isfinite(array).all():
            self.fail(where, f"key '{key}' must be a list of {size} finite numbers, got {value!r}")
        return array


def _scene_table(ctx: _Context, table: dict, frames: tuple[int, int] | None, default_name: str):
    ctx.check_keys(table, SCENE_KEYS, "scene")
    fps = ctx.number(table, "fps", "scene", default=24.0)
    if not 0 < fps <= MAX_FPS:
        ctx.fail("scene", f"key 'fps' = {fps:g} is not a frame rate; give a positive number up to {MAX_FPS:g}")
    frame_range = frames if frames is not None else table.get("frames", [1, 48])
    if (
        not isinstance(frame_range, (list, tuple))
        or len(frame_range) != 2
        or not all(isinstance(f, int) and not isinstance(f, bool) for f in frame_range)
    ):
        ctx.fail("scene", f"key 'frames' must be [start, end] integers, got {frame_range!r}")
    start, end = frame_range
    if end < start:
        ctx.fail("scene", f"key 'frames' = [{start}, {end}] runs backwards; give [start, end] with end >= start")
    mpu = ctx.number(table, "meters_per_unit", "scene", default=1.0)
    if not mpu > 0:
        ctx.fail("scene", f"key 'meters_per_unit' = {mpu:g} must be positive (1 for metres, 0.01 for centimetres)")
    up_axis = table.get("up_axis", "Y")
    if up_axis not in ("Y", "Z"):
        ctx.fail("scene", f"key 'up_axis' = {up_axis!r}; use \"Y\" or \"Z\"")
    up = np.array([0.0, 1.0, 0.0]) if up_axis == "Y" else np.array([0.0, 0.0, 1.0])
    if "gravity" in table:
        gravity = ctx.vector(table, "gravity", "scene")
    else:
        gravity = -up * STANDARD_GRAVITY / mpu
    if np.linalg.norm(gravity) * mpu > 1000.0:
        ctx.fail("scene", f"key 'gravity' is {np.linalg.norm(gravity) * mpu:.3g} m/s^2; it is in scene units/s^2 (check meters_per_unit)")
    name = table.get("name", default_name)
    if not isinstance(name, str) or not name.strip():
        ctx.fail("scene", f"key 'name' must be a non-empty string, got {name!r}; e.g. name = \"shot_010\"")
    return name, fps, int(start), int(end), mpu, up_axis, gravity


def preroll_of(ctx: _Context, table: dict) -> int:
    """``scene.preroll``: whole frames simulated before the start frame (0 = none)."""
    preroll = table.get("preroll", 0)
    if isinstance(preroll, bool) or not isinstance(preroll, int) or preroll < 0:
        ctx.fail("scene", f"key 'preroll' = {preroll!r} must be a whole number of frames, 0 or more")
    return int(preroll)


def _output_table(ctx: _Context, table: dict) -> OutputSettings:
    ctx.check_keys(table, OUTPUT_KEYS, "output")
    attributes = table.get("attributes", ["velocities"])
    if not isinstance(attributes, list) or any(a not in OUTPUT_ATTRIBUTES for a in attributes):
        ctx.fail("output", f"key 'attributes' = {attributes!r}; choose from {', '.join(OUTPUT_ATTRIBUTES)}")
    compression = table.get("compression", "gzip")
    if compression not in COMPRESSIONS:
        ctx.fail("output", f"key 'compression' = {compression!r}; use one of {', '.join(COMPRESSIONS)}")
    save_every = table.get("save_every", 10)
    if isinstance(save_every, bool) or not isinstance(save_every, int) or save_every < 1:
        ctx.fail("output", f"key 'save_every' = {save_every!r} must be a positive integer")
    return OutputSettings(frozenset(attributes), compression, save_every)


def _rotation(ctx: _Context, table: dict, where: str) -> np.ndarray:
    if "rotate" in table and "rotate_euler" in table:
        ctx.fail(where, "give either 'rotate' (quaternion w, x, y, z) or 'rotate_euler' (degrees), not both")
    if "rotate" in table:
        q = ctx.vector(table, "rotate", where, size=4)
        if np.linalg.norm(q) < 1e-9:
            ctx.fail(where, "key 'rotate' is a zero quaternion; give (w, x, y, z) of a rotation")
        return quat_to_matrix(q)
    if "rotate_euler" in table:
        return quat_to_matrix(euler_xyz_to_quat(ctx.vector(table, "rotate_euler", where)))
    return np.eye(3)


def _fabric_of(ctx: _Context, name: str, table: dict, strict: bool) -> tuple[str, Fabric, tuple[str, ...]]:
    where = f"cloth.{name}"
    if ("fabric" in table) == ("mesh" in table):
        ctx.fail(where, "give either 'fabric' (a cooked .fabric.h5) or 'mesh' (cooked when the scene loads)")
    loaders = ctx.loaders
    if "fabric" in table:
        if "cook" in table:
            ctx.fail(where, "key 'cook' applies to 'mesh' only; cook options of a fabric were fixed when it was cooked")
        source = str(table["fabric"])
        try:
            return source, loaders.read_fabric(ctx.base / source), ()
        except ClothtoolError as exc:
            ctx.fail(where, f"fabric: {exc}")
    source = str(table["mesh"])
    cook = table.get("cook", {})
    if isinstance(cook, str):
        cook = {"preset": cook}
    if not isinstance(cook, dict):
        ctx.fail(where, "key 'cook' must be a table of cook options (or a cook preset name)")
    cook = dict(cook)
    try:
        if "pin_file" in cook:
            cook["pin_file"] = str(ctx.base / str(cook["pin_file"]))
        options = loaders.cook_options(cook, f"{ctx.path}: [{where}.cook]", {"strict": strict})
        mesh_path = ctx.base / source
        mesh = loaders.read_mesh(mesh_path, None)
        fabric, warnings = loaders.cook(mesh, options, hashlib.sha256(mesh_path.read_bytes()).hexdigest())
    except ClothtoolError as exc:
        ctx.fail(where, f"mesh: {exc}")
    return source, fabric, warnings


def _cloth(ctx: _Context, name: str, table: dict, tracks: dict[str, Track], strict: bool) -> ClothInstance:
    where = f"cloth.{name}"
    ctx.check_keys(table, CLOTH_KEYS, where)
    source, fabric, warnings = _fabric_of(ctx, name, table, strict)
    try:
        material = load_material(table.get("material", "cotton"), f"{ctx.path}: [{where}.material]")
    except ClothtoolError as exc:
        raise SceneError(_nested(exc, ctx.path, f"{ctx.path}: [{where}] material:")) from None
    scale = ctx.number(table, "scale", where, default=1.0, positive=True)
    placement = Placement(
        scale=scale,
        rotation=_rotation(ctx, table, where),
        translation=ctx.vector(table, "translate", where, default=[0.0, 0.0, 0.0]),
    )
    track = ctx.track(table, where, tracks)
    motion_table = ctx.check_keys(table.get("motion", {}), ("scale", "bias", "stiffness"), f"{where}.motion")
    motion = MotionSettings(
        scale=ctx.number(motion_table, "scale", f"{where}.motion", default=1.0),
        bias=ctx.number(motion_table, "bias", f"{where}.motion", default=0.0),
        stiffness=ctx.number(motion_table, "stiffness", f"{where}.motion", default=1.0),
    )
    if not 0.0 <= motion.stiffness <= 1.0:
        ctx.fail(f"{where}.motion", "key 'stiffness' must lie in [0, 1]")
    backstop = None
    if "backstop" in table:
        back = ctx.check_keys(table["backstop"], ("radius", "distance"), f"{where}.backstop")
        backstop = BackstopSettings(
            radius=ctx.number(back, "radius", f"{where}.backstop", positive=True),
            distance=ctx.number(back, "distance", f"{where}.backstop", default=0.0),
        )
    velocity = ctx.vector(table, "initial_velocity", where, default=[0.0, 0.0, 0.0])
    attach = table.get("attach", [])
    if isinstance(attach, str):
        attach = [attach]
    if not isinstance(attach, list) or not all(isinstance(a, str) for a in attach):
        ctx.fail(where, f"key 'attach' = {attach!r} must name mesh colliders, e.g. attach = [\"body\"]")
    if attach and track is not None:
        ctx.fail(where, "give either 'track' or 'attach': an attached cloth follows its body, not a track")
    return ClothInstance(name, source, fabric, material, placement, track, motion, backstop, velocity, warnings,
                         tuple(attach))


def _wind(ctx: _Context, table: dict, tracks: dict[str, Track]) -> WindSettings:
    ctx.check_keys(table, WIND_KEYS, "wind")
    track = ctx.track(table, "wind", tracks)
    velocity = ctx.vector(table, "velocity", "wind", default=[0.0, 0.0, 0.0])
    density = ctx.number(table, "fluid_density", "wind", default=1.2)
    if density < 0:
        ctx.fail("wind", "key 'fluid_density' must not be negative")
    return WindSettings(velocity, track, density)


def _keys(names, sub: dict | None = None) -> dict:
    return {name: (sub or {}).get(name) for name in names}


def _fields(cls) -> list[str]:
    return [f.name for f in dataclasses.fields(cls)]


def override_schema(cook_keys: tuple[str, ...]) -> dict:
    """The keys ``--set`` may name (see clothtool.scene.overrides.check_override_keys);
    ``cook_keys`` are the cook's option names (``SceneLoaders.cook_keys``)."""
    from clothtool.scene.colliders import COMMON_KEYS, KIND_KEYS
    from clothtool.settings import PhaseSettings

    phase = _keys(_fields(PhaseSettings))
    phases = {label: phase for label in ("vertical", "horizontal", "shearing", "bending")}
    material = _keys(["preset", *_fields(Material)], phases)
    cook = _keys(["preset", *cook_keys])
    cloth = _keys(CLOTH_KEYS, {
        "material": material, "cook": cook,
        "motion": _keys(("scale", "bias", "stiffness")), "backstop": _keys(("radius", "distance")),
    })
    collider_keys = list(COMMON_KEYS) + [k for keys in KIND_KEYS.values() for k in keys if k not in COMMON_KEYS]
    return {
        "version": None,
        "scene": _keys(SCENE_KEYS),
        "solver": _keys(["preset", *_fields(SolverConfig)]),
        "output": _keys(OUTPUT_KEYS),
        "wind": _keys(WIND_KEYS),
        "track": Named(_keys(TRACK_KEYS)),
        "cloth": Named(cloth),
        "collider": Named(_keys(dict.fromkeys(collider_keys))),
    }


def _nested(exc: ClothtoolError, path: Path, prefix: str) -> str:
    """``exc``'s message under ``prefix``, unless it already names the scene file (the
    settings loaders name the file and table themselves)."""
    text = str(exc)
    return text if text.startswith(str(path)) else f"{prefix} {text}"


_MAGIC = {b"\x89HDF": "an HDF5 file (a fabric or a cache)", b"PXR-USDC": "a USD crate file", b"glTF": "a binary glTF mesh"}


def _refuse_other_file_kinds(path: Path, mesh_suffixes: tuple[str, ...]) -> None:
    """A fabric, cache or mesh given where a scene belongs gets a hint, not a TOML error."""
    with path.open("rb") as handle:
        head = handle.read(8)
    kind = next((what for magic, what in _MAGIC.items() if head.startswith(magic)), None)
    if kind is None and path.suffix.lower() in mesh_suffixes:
        kind = f"a mesh or USD file ({path.suffix})"
    if kind is not None:
        raise SceneError(
            f"{path}: is {kind}, not a scene; bake takes a scene .toml (formats/scene/v1.md) whose "
            "[cloth.NAME] tables name fabrics or meshes"
        )


def read_scene(
    path: str | Path,
    loaders: SceneLoaders,
    overrides: list[str] = (),
    frames: tuple[int, int] | None = None,
    strict: bool = False,
) -> Scene:
    """Read and validate a scene file (see module docstring) with ``loaders``; ``strict``
    makes mesh repairs of cloths cooked on the fly errors."""
    path = Path(path)
    if not path.exists():
        raise SceneError(f"{path}: scene file not found; check the path")
    if path.is_file():  # a device or FIFO is refused unread by read_toml
        _refuse_other_file_kinds(path, loaders.mesh_suffixes)
    raw = read_toml(path, error=SceneError)  # refuses devices, FIFOs and huge files unread
    check_override_keys(raw, list(overrides), override_schema(loaders.cook_keys))
    tables = apply_overrides(raw, list(overrides))
    ctx = _Context(path, loaders)
    unknown = [k for k in tables if k not in TOP_LEVEL_KEYS]
    if unknown:
        raise SceneError(f"{path}: unknown top-level key '{unknown[0]}'; allowed: {', '.join(TOP_LEVEL_KEYS)}")
    version = tables.get("version", FORMAT_VERSION)
    if version != FORMAT_VERSION:
        raise SceneError(f"{path}: scene version {version!r} is not supported; this clothtool reads version {FORMAT_VERSION}")
    name, fps, start, end, mpu, up_axis, gravity = _scene_table(ctx, tables.get("scene", {}), frames, path.stem)
    try:
        solver = load_solver(tables.get("solver", "production"), f"{path}: [solver]")
    except ClothtoolError as exc:
        raise SceneError(_nested(exc, path, f"{path}: [solver]")) from None
    output = _output_table(ctx, tables.get("output", {}))
    track_tables = tables.get("track", {})
    if not isinstance(track_tables, dict):
        ctx.fail("track", "must be tables like [track.NAME]")
    tracks = {}
    for track_name, track_table in track_tables.items():
        try:
            tracks[track_name] = load_track(track_name, track_table, fps, ctx.base)
        except ClothtoolError as exc:
            raise SceneError(f"{path}: {exc}") from None
    cloth_tables = tables.get("cloth", {})
    if not isinstance(cloth_tables, dict) or not cloth_tables:
        raise SceneError(f"{path}: the scene has no cloth; add a [cloth.NAME] table with a 'fabric' or 'mesh'")
    cloths = tuple(_cloth(ctx, name, table, tracks, strict) for name, table in cloth_tables.items())
    for cloth in cloths:
        if not cloth.name.replace("_", "a").isalnum() or cloth.name[0].isdigit():
            ctx.fail(f"cloth.{cloth.name}", "cloth names must be letters, digits and underscores, not starting with a digit")
    wind = _wind(ctx, tables["wind"], tracks) if "wind" in tables else None
    preroll = preroll_of(ctx, tables.get("scene", {}))
    colliders = None
    if "collider" in tables:
        from clothtool.scene.colliders import Shot, load_colliders

        colliders = load_colliders(ctx, tables["collider"], tracks, Shot(fps, start, end, preroll, mpu, up_axis))
    for cloth in cloths:
        kinds = {c.name: c.kind for c in colliders.colliders} if colliders is not None else {}
        missing = [a for a in cloth.attach if kinds.get(a) != "mesh"]
        if missing:
            meshes = [n for n, k in kinds.items() if k == "mesh"]
            ctx.fail(f"cloth.{cloth.name}", f"key 'attach' names '{missing[0]}', which is no mesh collider; mesh colliders: {', '.join(meshes) or 'none'}")
    return Scene(name, path, fps, start, end, mpu, up_axis, gravity, solver, cloths, wind, tracks, output, colliders, preroll)
