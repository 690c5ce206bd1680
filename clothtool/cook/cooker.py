"""cook_fabric: a garment mesh in, a validated Fabric out."""

from __future__ import annotations

import dataclasses
import hashlib
import json
import time
from pathlib import Path

import numpy as np

from clothtool.cook import locality, paint
from clothtool.cook.adjacency import AdjacencyQuerier
from clothtool.cook.phases import build_phases
from clothtool.cook.tethers import build_tethers
from clothtool.cook.tiles import schedule_tiles
from clothtool.cook.virtual import WEIGHT_PATTERNS, build_virtual_particles
from clothtool.errors import MeshError
from clothtool.fabric import Fabric, PhaseType
from clothtool.mesh import topology
from clothtool.mesh.clothmesh import ClothMesh
from clothtool.mesh.prepare import bounding_box_diagonal, prepare_mesh

UP_VECTORS = {"Y": (0.0, 1.0, 0.0), "Z": (0.0, 0.0, 1.0)}
TETHER_MODES = ("auto", "geodesic", "euclidean", "none")
# A garment outside this size range (metres across) probably has the wrong unit.
PLAUSIBLE_SIZE_M = (0.01, 100.0)


@dataclasses.dataclass(frozen=True)
class CookOptions:
    """How to cook a mesh. Every field has a command-line option of the same name.

    Lengths (pin box, max-distance range) are in the mesh file's units.
    """

    weld: float = 1e-6
    meters_per_unit: float | None = None
    up_axis: str | None = None
    hang_direction: tuple[float, float, float] | None = None
    recover_quads: bool = True
    shearing: bool = True
    bending: bool = True
    tethers: str = "auto"
    tether_anchors: int = 1
    pin_attr: str | None = None
    pin_threshold: float = 0.5
    pin_box: tuple[float, float, float, float, float, float] | None = None
    pin_file: str | None = None
    max_distance_attr: str | None = None
    max_distance_range: tuple[float, float] = (0.0, 1.0)
    stiffness_attr: str | None = None
    virtual_particles: int = 0
    reorder: bool = True
    strict: bool = False

    def check(self) -> None:
        if not (0 <= self.weld < 1):
            raise MeshError(f"--weld {self.weld:g}: the tolerance is relative to the bounding box and must lie in [0, 1)")
        if self.meters_per_unit is not None and not (self.meters_per_unit > 0 and np.isfinite(self.meters_per_unit)):
            raise MeshError(f"--meters-per-unit {self.meters_per_unit:g} must be a positive number")
        if self.up_axis is not None and self.up_axis not in UP_VECTORS:
            raise MeshError(f"--up-axis {self.up_axis}: use Y or Z")
        if self.tethers not in TETHER_MODES:
            raise MeshError(f"--tethers {self.tethers}: use one of {', '.join(TETHER_MODES)}")
        if self.tether_anchors < 1:
            raise MeshError(f"--tether-anchors {self.tether_anchors}: need at least 1")
        if self.virtual_particles not in (0, *WEIGHT_PATTERNS):
            allowed = ", ".join(str(k) for k in (0, *WEIGHT_PATTERNS))
            raise MeshError(f"--virtual-particles {self.virtual_particles}: use one of {allowed}")
        if not (0 < self.pin_threshold <= 1):
            raise MeshError(f"--pin-threshold {self.pin_threshold:g} must lie in (0, 1]")
        if self.hang_direction is not None and not np.linalg.norm(self.hang_direction) > 0:
            raise MeshError("--hang-direction must be a non-zero vector")

    def provenance(self) -> str:
        """Canonical JSON of the options: no absolute paths (a pin file is named and hashed)."""
        data = dataclasses.asdict(self)
        if self.pin_file is not None:
            data["pin_file"] = {
                "name": Path(self.pin_file).name,
                "sha256": hashlib.sha256(Path(self.pin_file).read_bytes()).hexdigest(),
            }
        return json.dumps(data, sort_keys=True, separators=(",", ":"))


@dataclasses.dataclass(frozen=True)
class PhaseStats:
    phase_type: str
    constraints: int
    sets: int
    lower_bound: int


@dataclasses.dataclass(frozen=True)
class CookResult:
    """A cooked fabric plus what a user wants to know about the cook."""

    fabric: Fabric
    warnings: list[str]
    welded_vertices: int
    phases: list[PhaseStats]
    tether_fallbacks: int
    seconds: dict[str, float]


def _pinned_mask(mesh: ClothMesh, options: CookOptions, vertex_map: np.ndarray) -> np.ndarray:
    n = mesh.vertex_count
    pinned = np.zeros(n, bool)
    if options.pin_attr is not None:
        pinned |= paint.pin_mask_from_attribute(mesh, options.pin_attr, options.pin_threshold)
    if options.pin_box is not None:
        pinned |= paint.pin_mask_from_box(mesh.vertex_pos.astype(np.float64), options.pin_box)
    if options.pin_file is not None:
        indices = paint.read_index_file(options.pin_file)
        pinned |= paint.pin_mask_from_indices(indices, vertex_map, mesh.source, n)
    return pinned


def _schedule(phases, pos: np.ndarray, movable: np.ndarray, stiffness: np.ndarray | None):
    """Schedule each phase into sets, tile by tile (clothtool.cook.tiles); returns the
    fabric's phase/set/constraint arrays and one PhaseStats per phase type.

    The fabric lists its phases tile-major: every phase's part of tile 0 in NvCloth's phase
    order, then of tile 1, ...; a cloth of one tile gets each phase once, as untiled."""
    scheduled = [(phase, schedule_tiles(phase.pairs, movable)) for phase in phases]
    tiles = np.unique(np.concatenate([s.tiles for _, s in scheduled] or [np.zeros(0, np.int64)]))
    phase_types, phase_set_offsets, set_offsets = [], [0], [0]
    indices, stats = [], []
    for tile in tiles.tolist():
        for phase, schedule in scheduled:
            at = np.searchsorted(schedule.tiles, tile)
            if at == schedule.tiles.shape[0] or schedule.tiles[at] != tile:
                continue
            first_set, last_set = schedule.tile_set_offsets[at], schedule.tile_set_offsets[at + 1]
            first, last = schedule.offsets[first_set], schedule.offsets[last_set]
            indices.append(phase.pairs[schedule.order[first:last]])
            phase_types.append(int(phase.phase_type))
            set_offsets.extend((schedule.offsets[first_set + 1:last_set + 1] - first + set_offsets[-1]).tolist())
            phase_set_offsets.append(phase_set_offsets[-1] + int(last_set - first_set))
    for phase, schedule in scheduled:
        stats.append(
            PhaseStats(PhaseType(phase.phase_type).label, int(phase.pairs.shape[0]), schedule.set_count, schedule.lower_bound)
        )
    pairs = np.concatenate(indices) if indices else np.zeros((0, 2), np.int64)
    rest = np.linalg.norm(pos[pairs[:, 1]] - pos[pairs[:, 0]], axis=1)
    if stiffness is None:
        constraint_stiffness = np.ones(pairs.shape[0], np.float32)
    else:
        constraint_stiffness = (0.5 * (stiffness[pairs[:, 0]] + stiffness[pairs[:, 1]])).astype(np.float32)
    arrays = dict(
        phase_type=np.asarray(phase_types, np.int32),
        phase_set_offsets=np.asarray(phase_set_offsets, np.int32),
        set_offsets=np.asarray(set_offsets, np.int32),
        constraint_indices=pairs.astype(np.int32),
        constraint_rest_length=rest.astype(np.float32),
        constraint_stiffness=constraint_stiffness,
    )
    return arrays, stats


def cook_fabric(mesh: ClothMesh, options: CookOptions = CookOptions(), source_sha256: str = "") -> CookResult:
    """Cook ``mesh`` into a Fabric (see the module docs of each step).

    Raises MeshError on bad input; repairs are listed in ``CookResult.warnings``.
    """
    options.check()
    seconds: dict[str, float] = {}
    clock = time.perf_counter()

    def lap(name: str) -> None:
        nonlocal clock
        now = time.perf_counter()
        seconds[name] = now - clock
        clock = now

    prepared = prepare_mesh(mesh, options.weld, options.strict)
    clean, vertex_map = prepared.mesh, prepared.vertex_map
    # Particles are numbered for memory locality (clothtool.cook.locality); the fabric keeps
    # the cleaned mesh's vertex of each particle so that caches come out in vertex order.
    particle_vertex = np.zeros(0, np.int32)
    if options.reorder:
        order = locality.rcm_order(clean)
        clean = locality.reorder_mesh(clean, order)
        vertex_map = locality.renumber_vertex_map(vertex_map, order)
        particle_vertex = order.astype(np.int32)
    if options.strict and mesh.warnings:
        raise MeshError(f"{mesh.warnings[0].replace(': warning: ', ': ', 1)} (an error because of --strict)")
    warnings = list(mesh.warnings) + list(prepared.warnings)
    pos = clean.vertex_pos.astype(np.float64)
    n = clean.vertex_count
    meters_per_unit = float(options.meters_per_unit or clean.meters_per_unit or 1.0)
    up_axis = options.up_axis or clean.up_axis or "Y"
    hang = np.asarray(options.hang_direction or tuple(-c for c in UP_VECTORS[up_axis]), np.float64)
    hang /= np.linalg.norm(hang)
    size_m = bounding_box_diagonal(clean.vertex_pos) * meters_per_unit
    if not (PLAUSIBLE_SIZE_M[0] <= size_m <= PLAUSIBLE_SIZE_M[1]):
        what = f"the garment is {size_m:.3g} m across at {meters_per_unit:g} m per unit"
        fix = "check --meters-per-unit (0.01 for centimetres)"
        if options.strict:
            raise MeshError(f"{mesh.source}: {what}; {fix} (an error because of --strict)")
        warnings.append(f"{mesh.source}: warning: {what}; {fix}")
    lap("prepare")

    adjacency = AdjacencyQuerier(clean.face_vertex_counts, clean.face_vertex_indices, n)
    phases = build_phases(
        pos, clean.face_vertex_counts, clean.face_vertex_indices, adjacency, hang,
        recover_quads=options.recover_quads, shearing=options.shearing, bending=options.bending,
    )
    lap("phases")

    pinned = _pinned_mask(clean, options, vertex_map)
    stiffness = paint.stiffness_from_attribute(clean, options.stiffness_attr) if options.stiffness_attr else None
    max_distance = np.full(n, np.inf, np.float32)
    if options.max_distance_attr is not None:
        max_distance = paint.max_distance_from_attribute(clean, options.max_distance_attr, *options.max_distance_range)
    movable = ~pinned
    triangles, _ = topology.triangulate(clean.face_vertex_counts, clean.face_vertex_indices)
    area = topology.vertex_areas(pos, clean.face_vertex_counts, clean.face_vertex_indices) * meters_per_unit**2
    inv_mass = np.where(pinned, 0.0, 1.0 / area).astype(np.float32)
    lap("paint")

    arrays, phase_stats = _schedule(phases, pos, movable, stiffness)
    lap("schedule")

    tether_mode = options.tethers
    if tether_mode == "auto":
        tether_mode = "geodesic" if pinned.any() else "none"
    fallbacks = 0
    if tether_mode != "none":
        if not pinned.any():
            raise MeshError(
                f"{mesh.source}: --tethers {tether_mode} needs pinned particles but none are pinned; "
                "pin some with --pin-attr, --pin-box or --pin-file, or pass --tethers none"
            )
        structural = {PhaseType.VERTICAL, PhaseType.HORIZONTAL, PhaseType.SHEARING}
        graph_edges = np.concatenate(
            [p.pairs for p in phases if p.phase_type in structural] or [np.zeros((0, 2), np.int64)]
        )
        tethers = build_tethers(pos, graph_edges, triangles, pinned, tether_mode, options.tether_anchors)
        tether_anchor, tether_length, fallbacks = tethers.anchor, tethers.length, tethers.unreachable
        warnings.extend(f"{mesh.source}: warning: {note}" for note in tethers.notes)
    else:
        tether_anchor, tether_length = np.zeros(0, np.int32), np.zeros(0, np.float32)
    lap("tethers")

    virtual, virtual_weights, virtual_offsets = build_virtual_particles(
        triangles, movable, options.virtual_particles
    )
    lap("virtual")

    fabric = Fabric(
        rest_pos=clean.vertex_pos.astype(np.float32),
        particle_inv_mass=inv_mass,
        particle_area=area.astype(np.float32),
        particle_max_distance=max_distance,
        triangles=triangles.astype(np.int32),
        face_vertex_counts=clean.face_vertex_counts.astype(np.int32),
        face_vertex_indices=clean.face_vertex_indices.astype(np.int32),
        face_vertex_uv=(
            clean.face_vertex_uv if clean.face_vertex_uv is not None else np.zeros((0, 2), np.float32)
        ),
        tether_anchor=tether_anchor,
        tether_rest_length=tether_length,
        virtual_particles=virtual,
        virtual_particle_weights=virtual_weights,
        virtual_batch_offsets=virtual_offsets,
        particle_vertex=particle_vertex,
        meters_per_unit=meters_per_unit,
        up_axis=up_axis,
        hang_direction=hang.astype(np.float32),
        source_sha256=source_sha256,
        cook_options=options.provenance(),
        **arrays,
    )
    fabric.validate()
    lap("validate")
    return CookResult(fabric, warnings, prepared.welded, phase_stats, fallbacks, seconds)
