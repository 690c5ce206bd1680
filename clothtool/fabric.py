"""The cooked fabric: NvCloth's fabric data with clear names, as flat numpy arrays.

A fabric is static: it holds what a cloth instance needs that does not change while it is
simulated (rest pose, constraints split into conflict-free sets, tethers, paint maps). It is
independent of the material: masses are stored per unit areal density.

Shapes use ``n`` particles, ``t`` triangles, ``f`` faces, ``p`` phases, ``s`` sets, ``c``
constraints, ``k`` tethers per particle, ``v`` virtual particles, ``w`` virtual weights,
``b`` virtual-particle batches. Every field is described in ``formats/fabric/v2.md``.
"""

from __future__ import annotations

import dataclasses
import functools
from enum import IntEnum

import numpy as np

from clothtool.errors import FabricError

FORMAT_NAME = "clothtool-fabric"
# Version 2 adds ``particle_vertex`` (particles renumbered for locality); a fabric without it
# is written as version 1, byte for byte as before, so that older readers still read it.
# A cloth of more than 16384 particles is cooked in cache tiles (clothtool.cook.tiles): its
# phase list repeats each phase type once per tile. Older readers read and solve that
# correctly, so it changed no version (formats/CHANGELOG.md).
FORMAT_VERSION = 2
READABLE_VERSIONS = (1, 2)


class PhaseType(IntEnum):
    """Constraint phase types; the values are NvCloth's ``ClothFabricPhaseType``."""

    VERTICAL = 1
    HORIZONTAL = 2
    BENDING = 3
    SHEARING = 4

    @property
    def label(self) -> str:
        return {1: "vertical", 2: "horizontal", 3: "bending", 4: "shearing"}[int(self)]


# (field name, dtype, shape with symbolic dims) for every array field, in file order.
ARRAY_FIELDS: tuple[tuple[str, type, tuple], ...] = (
    ("rest_pos", np.float32, ("n", 3)),
    ("particle_inv_mass", np.float32, ("n",)),
    ("particle_area", np.float32, ("n",)),
    ("particle_max_distance", np.float32, ("n",)),
    ("triangles", np.int32, ("t", 3)),
    ("face_vertex_counts", np.int32, ("f",)),
    ("face_vertex_indices", np.int32, ("fv",)),
    ("face_vertex_uv", np.float32, ("uv", 2)),
    ("phase_type", np.int32, ("p",)),
    ("phase_set_offsets", np.int32, ("p+1",)),
    ("set_offsets", np.int32, ("s+1",)),
    ("constraint_indices", np.int32, ("c", 2)),
    ("constraint_rest_length", np.float32, ("c",)),
    ("constraint_stiffness", np.float32, ("c",)),
    ("tether_anchor", np.int32, ("kn",)),
    ("tether_rest_length", np.float32, ("kn",)),
    ("virtual_particles", np.int32, ("v", 4)),
    ("virtual_particle_weights", np.float32, ("w", 3)),
    ("virtual_batch_offsets", np.int32, ("b+1",)),
    ("particle_vertex", np.int32, ("n or 0",)),
)
# Fields a version-1 file does not hold: read as empty (particles in vertex order).
OPTIONAL_ARRAY_FIELDS = ("particle_vertex",)
ARRAY_FIELD_NAMES = tuple(name for name, _, _ in ARRAY_FIELDS)

# Scalar/string metadata stored as HDF5 root attributes.
ATTR_FIELDS = ("meters_per_unit", "up_axis", "hang_direction", "source_sha256", "cook_options")


@dataclasses.dataclass(frozen=True, eq=False)
class Fabric:
    """Cooked cloth data (see module docstring and ``formats/fabric/v2.md``).

    Attributes:
        rest_pos: f32 (n,3) particle positions of the cooking pose, in fabric units.
        particle_inv_mass: f32 (n,) inverse mass in 1/kg for an areal density of 1 kg/m^2;
            0 marks a pinned particle. Divide by the material's areal density to get 1/kg.
        particle_area: f32 (n,) lumped area per particle in m^2 (each face's area split
            evenly among its corners).
        particle_max_distance: f32 (n,) motion-constraint radius in fabric units; +inf where
            the particle is free.
        triangles: i32 (t,3) triangulation used by wind, collision and the implicit solver.
        face_vertex_counts, face_vertex_indices: the render topology (quads kept), as in USD.
        face_vertex_uv: f32 (fv,2) per-face-vertex UVs, or (0,2) when the mesh had none.
        phase_type: i32 (p,) ``PhaseType`` of each phase (a type repeats once per cache tile
            in a big cloth, clothtool.cook.tiles).
        phase_set_offsets: i32 (p+1,) CSR: phase i owns sets [offsets[i], offsets[i+1]).
        set_offsets: i32 (s+1,) CSR: set j owns constraints [offsets[j], offsets[j+1]).
        constraint_indices: i32 (c,2) particle pairs; no movable particle twice in a set.
        constraint_rest_length: f32 (c,) rest lengths in fabric units.
        constraint_stiffness: f32 (c,) per-constraint stiffness multiplier in [0,1].
        tether_anchor: i32 (k*n,) anchor particle of tether i, which acts on particle i % n.
        tether_rest_length: f32 (k*n,) tether lengths in fabric units.
        virtual_particles: i32 (v,4) three particle indices and a row of
            ``virtual_particle_weights``; ordered in conflict-free batches.
        virtual_particle_weights: f32 (w,3) barycentric weights.
        virtual_batch_offsets: i32 (b+1,) CSR into ``virtual_particles``.
        particle_vertex: i32 (n,) the vertex of the cooked (welded) mesh that particle i is,
            when the cook renumbered the particles for memory locality; (0,) when particle i
            is vertex i. Caches present points in vertex order (``in_vertex_order``).
        meters_per_unit: size of one fabric unit in metres.
        up_axis: "Y" or "Z".
        hang_direction: f32 (3,) unit vector that separates vertical from horizontal stretch.
        source_sha256: hash of the input mesh file's bytes ("" if built in memory).
        cook_options: canonical JSON of the cook options that produced this fabric.
    """

    rest_pos: np.ndarray
    particle_inv_mass: np.ndarray
    particle_area: np.ndarray
    particle_max_distance: np.ndarray
    triangles: np.ndarray
    face_vertex_counts: np.ndarray
    face_vertex_indices: np.ndarray
    face_vertex_uv: np.ndarray
    phase_type: np.ndarray
    phase_set_offsets: np.ndarray
    set_offsets: np.ndarray
    constraint_indices: np.ndarray
    constraint_rest_length: np.ndarray
    constraint_stiffness: np.ndarray
    tether_anchor: np.ndarray
    tether_rest_length: np.ndarray
    virtual_particles: np.ndarray
    virtual_particle_weights: np.ndarray
    virtual_batch_offsets: np.ndarray
    particle_vertex: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(0, np.int32))
    meters_per_unit: float = 1.0
    up_axis: str = "Y"
    hang_direction: np.ndarray = dataclasses.field(
        default_factory=lambda: np.array([0.0, -1.0, 0.0], np.float32)
    )
    source_sha256: str = ""
    cook_options: str = "{}"

    # ----------------------------------------------------------------- derived sizes
    @property
    def particle_count(self) -> int:
        return int(self.rest_pos.shape[0])

    @property
    def phase_count(self) -> int:
        return int(self.phase_type.shape[0])

    @property
    def set_count(self) -> int:
        return int(self.set_offsets.shape[0]) - 1

    @property
    def constraint_count(self) -> int:
        return int(self.constraint_indices.shape[0])

    @property
    def tethers_per_particle(self) -> int:
        n = self.particle_count
        return int(self.tether_anchor.shape[0]) // n if n else 0

    @property
    def pinned(self) -> np.ndarray:
        """Boolean (n,) mask of pinned particles."""
        return self.particle_inv_mass == 0

    @property
    def reordered(self) -> bool:
        """True when the particles are numbered apart from the mesh's vertices."""
        return bool(self.particle_vertex.shape[0])

    @functools.cached_property
    def vertex_particle(self) -> np.ndarray | None:
        """i64 (n,): the particle of each mesh vertex, or None when particle i is vertex i
        (computed once: the bake rearranges every frame's points with it)."""
        if not self.reordered:
            return None
        inverse = np.empty(self.particle_count, np.int64)
        inverse[self.particle_vertex] = np.arange(self.particle_count, dtype=np.int64)
        return inverse

    def in_vertex_order(self, values: np.ndarray) -> np.ndarray:
        """Per-particle ``values`` (n, ...) rearranged into the mesh's vertex order: a copy
        when the particles were renumbered, ``values`` itself otherwise."""
        # np.take gathers whole rows: 4x faster than values[index] (0.04 vs 0.17 ms at 128^2).
        return values if self.vertex_particle is None else np.take(values, self.vertex_particle, axis=0)

    def vertex_of(self, particle: int) -> int:
        """The mesh vertex that ``particle`` is (for messages that name an element)."""
        return int(self.particle_vertex[particle]) if self.reordered and 0 <= particle < self.particle_count else particle

    def vertex_numbers(self, particles: np.ndarray) -> np.ndarray:
        """Particle indices (any shape) as the mesh's vertex numbers."""
        return self.particle_vertex[particles] if self.reordered else particles

    def vertex_face_indices(self) -> np.ndarray:
        """i32 (fv,) ``face_vertex_indices`` as mesh vertex numbers (the render topology)."""
        return self.vertex_numbers(self.face_vertex_indices)

    def phase_constraints(self, phase: int) -> slice:
        """Slice of the constraint arrays that belongs to phase ``phase``."""
        first_set = self.phase_set_offsets[phase]
        last_set = self.phase_set_offsets[phase + 1]
        return slice(int(self.set_offsets[first_set]), int(self.set_offsets[last_set]))

    def replace(self, **changes) -> "Fabric":
        return dataclasses.replace(self, **changes)

    # ----------------------------------------------------------------- validation
    def validate(self) -> None:
        """Check dtypes, shapes, index ranges, CSR monotonicity and conflict-freedom.

        Raises FabricError naming the first offending field and element.
        """
        _validate(self)


def _fail(field: str, message: str) -> None:
    raise FabricError(f"fabric field '{field}': {message}")


def _check_dtype_shape(fabric: Fabric) -> None:
    n = fabric.particle_count
    for name, dtype, shape in ARRAY_FIELDS:
        array = getattr(fabric, name)
        if not isinstance(array, np.ndarray):
            _fail(name, f"expected a numpy array, got {type(array).__name__}")
        if array.dtype != dtype:
            _fail(name, f"dtype {array.dtype}, expected {np.dtype(dtype)}")
        if array.ndim != len(shape):
            _fail(name, f"has {array.ndim} dimensions, expected {len(shape)}")
        for axis, dim in enumerate(shape):
            if dim == "n or 0" and array.shape[axis] not in (0, n):
                _fail(name, f"shape {array.shape}, axis {axis} must be the particle count {n} or 0")
            if isinstance(dim, int) and array.shape[axis] != dim:
                _fail(name, f"shape {array.shape}, axis {axis} must be {dim}")
            if dim == "n" and array.shape[axis] != n:
                _fail(name, f"shape {array.shape}, axis {axis} must be the particle count {n}")
        if array.dtype.kind == "f":
            # +inf is meaningful only as "no motion constraint" in particle_max_distance.
            ok = np.isfinite(array)
            if name == "particle_max_distance":
                ok |= np.isposinf(array)
            if not ok.all():
                bad = int(np.flatnonzero(~ok.reshape(ok.shape[0], -1).all(axis=1))[0])
                _fail(name, f"row {bad} is NaN or infinite")


def _check_csr(name: str, offsets: np.ndarray, end: int) -> None:
    if offsets.shape[0] == 0:
        _fail(name, "must have at least one entry (the leading 0)")
    if offsets[0] != 0:
        _fail(name, f"must start at 0, starts at {offsets[0]}")
    steps = np.diff(offsets)
    if np.any(steps < 0):
        _fail(name, f"decreases at index {int(np.flatnonzero(steps < 0)[0]) + 1}")
    if offsets[-1] != end:
        _fail(name, f"ends at {offsets[-1]}, expected {end}")


def _check_index_range(name: str, indices: np.ndarray, count: int) -> None:
    if indices.size and (indices.min() < 0 or indices.max() >= count):
        flat = indices.reshape(indices.shape[0], -1)
        row = int(np.flatnonzero(((flat < 0) | (flat >= count)).any(axis=1))[0])
        _fail(name, f"row {row} holds {flat[row].tolist()}, outside [0, {count})")


def _check_not_negative(name: str, values: np.ndarray, what: str = "values") -> None:
    if values.size and np.any(values < 0):
        entry = int(np.flatnonzero(values < 0)[0])
        _fail(name, f"holds negative {what} (entry {entry} is {float(values[entry]):g}); they must be >= 0")


def _check_hang_direction(hang) -> None:
    hang = np.asarray(hang)
    if hang.shape != (3,) or hang.dtype.kind not in "iuf":
        _fail("hang_direction", f"has shape {hang.shape}, expected 3 numbers (a unit vector)")
    if not np.isfinite(hang).all():
        _fail("hang_direction", "holds NaN or infinite values; it must be a unit vector")
    if abs(float(np.linalg.norm(hang.astype(np.float64))) - 1.0) > 1e-3:
        _fail("hang_direction", f"has length {float(np.linalg.norm(hang)):.4g}; it must be a unit vector")


# Virtual particles are collided BATCH_WIDTH at a time (NvCloth's CPU SIMD width).
VIRTUAL_BATCH_WIDTH = 4


def _check_virtual_batches(fabric: Fabric) -> None:
    """At most VIRTUAL_BATCH_WIDTH per batch, and no movable particle twice in a batch."""
    offsets = fabric.virtual_batch_offsets
    sizes = np.diff(offsets)
    if sizes.size and sizes.max() > VIRTUAL_BATCH_WIDTH:
        batch = int(np.argmax(sizes))
        _fail("virtual_batch_offsets", f"batch {batch} holds {int(sizes[batch])} virtual particles; at most {VIRTUAL_BATCH_WIDTH} per batch")
    # A movable particle twice in one batch shows up as a repeated (batch, particle) key.
    batch_of_row = np.repeat(np.arange(sizes.shape[0], dtype=np.int64), sizes)
    particles = fabric.virtual_particles[: batch_of_row.shape[0], :3].astype(np.int64)
    batches = np.repeat(batch_of_row, 3)
    particles = particles.reshape(-1)
    movable = fabric.particle_inv_mass[particles] > 0
    keys = np.sort(batches[movable] * fabric.particle_count + particles[movable])
    repeated = keys[1:][keys[1:] == keys[:-1]]
    if repeated.size:
        batch, particle = divmod(int(repeated[0]), fabric.particle_count)
        _fail("virtual_batch_offsets", f"batch {batch} uses movable particle {particle} twice; batches must share no particle")


def conflicting_set(fabric: Fabric) -> tuple[int, int] | None:
    """Return (set, particle) for the first set in which a movable particle appears twice."""
    movable = fabric.particle_inv_mass > 0
    for s in range(fabric.set_count):
        pairs = fabric.constraint_indices[fabric.set_offsets[s] : fabric.set_offsets[s + 1]]
        used = pairs.reshape(-1)
        used = used[movable[used]]
        counts = np.bincount(used, minlength=0)
        if counts.size and counts.max() > 1:
            return s, int(np.argmax(counts))
    return None


def _validate(fabric: Fabric) -> None:
    _check_dtype_shape(fabric)
    n = fabric.particle_count
    if n == 0:
        _fail("rest_pos", "fabric has no particles")
    _check_not_negative("particle_inv_mass", fabric.particle_inv_mass)
    _check_not_negative("particle_area", fabric.particle_area, "areas")
    _check_not_negative("particle_max_distance", fabric.particle_max_distance, "distances")
    _check_index_range("triangles", fabric.triangles, n)
    _check_index_range("face_vertex_indices", fabric.face_vertex_indices[:, None], n)
    if np.any(fabric.face_vertex_counts < 3):
        _fail("face_vertex_counts", "every face needs at least 3 vertices")
    if int(fabric.face_vertex_counts.sum()) != fabric.face_vertex_indices.shape[0]:
        _fail("face_vertex_indices", "length differs from the sum of face_vertex_counts")
    if fabric.face_vertex_uv.shape[0] not in (0, fabric.face_vertex_indices.shape[0]):
        _fail("face_vertex_uv", "must be empty or hold one UV per face vertex")
    _check_csr("phase_set_offsets", fabric.phase_set_offsets, fabric.set_count)
    if fabric.phase_set_offsets.shape[0] != fabric.phase_count + 1:
        _fail("phase_set_offsets", "length must be phase count + 1")
    valid_types = {int(t) for t in PhaseType}
    for i, t in enumerate(fabric.phase_type.tolist()):
        if t not in valid_types:
            _fail("phase_type", f"phase {i} has unknown type {t}")
    _check_csr("set_offsets", fabric.set_offsets, fabric.constraint_count)
    _check_index_range("constraint_indices", fabric.constraint_indices, n)
    c = fabric.constraint_count
    for name in ("constraint_rest_length", "constraint_stiffness"):
        if getattr(fabric, name).shape[0] != c:
            _fail(name, f"length must equal the constraint count {c}")
    _check_not_negative("constraint_rest_length", fabric.constraint_rest_length, "lengths")
    if np.any((fabric.constraint_stiffness < 0) | (fabric.constraint_stiffness > 1)):
        _fail("constraint_stiffness", "values must lie in [0, 1]")
    if fabric.tether_anchor.shape[0] % n:
        _fail("tether_anchor", f"length must be a multiple of the particle count {n}")
    if fabric.tether_rest_length.shape[0] != fabric.tether_anchor.shape[0]:
        _fail("tether_rest_length", "length must equal tether_anchor's")
    _check_index_range("tether_anchor", fabric.tether_anchor[:, None], n)
    _check_not_negative("tether_rest_length", fabric.tether_rest_length, "lengths")
    if fabric.tether_anchor.size:
        anchors = fabric.tether_anchor
        owners = np.arange(anchors.shape[0]) % n
        bad = (anchors != owners) & (fabric.particle_inv_mass[anchors] != 0)
        if np.any(bad):
            _fail("tether_anchor", f"tether {int(np.flatnonzero(bad)[0])} anchors to a movable particle")
    _check_index_range("virtual_particles", fabric.virtual_particles[:, :3], n)
    _check_index_range(
        "virtual_particles", fabric.virtual_particles[:, 3:], fabric.virtual_particle_weights.shape[0]
    )
    _check_csr("virtual_batch_offsets", fabric.virtual_batch_offsets, fabric.virtual_particles.shape[0])
    _check_virtual_batches(fabric)
    if fabric.reordered:
        seen = np.zeros(n, np.int64)
        _check_index_range("particle_vertex", fabric.particle_vertex[:, None], n)
        np.add.at(seen, fabric.particle_vertex, 1)
        if np.any(seen != 1):
            vertex = int(np.flatnonzero(seen != 1)[0])
            _fail("particle_vertex", f"names vertex {vertex} {int(seen[vertex])} times; it must be a permutation of 0..{n - 1}")
    if fabric.up_axis not in ("Y", "Z"):
        _fail("up_axis", f"is '{fabric.up_axis}', expected 'Y' or 'Z'")
    if not (np.isfinite(fabric.meters_per_unit) and fabric.meters_per_unit > 0):
        _fail("meters_per_unit", f"is {fabric.meters_per_unit}; it must be a positive finite number (1 for metres)")
    _check_hang_direction(fabric.hang_direction)
    conflict = conflicting_set(fabric)
    if conflict is not None:
        _fail("set_offsets", f"set {conflict[0]} uses movable particle {conflict[1]} twice")
