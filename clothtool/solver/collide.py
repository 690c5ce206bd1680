"""Stage: collision with the scene's colliders (NvCloth's collideParticles).

Once per frame the stage samples the environment's world-space colliders at the frame's
start and end, copies them into flat arrays it reuses from frame to frame, and grids the
triangle-mesh colliders. Each iteration it interpolates the colliders linearly to the
iteration's start (alpha0) and end (alpha1), moves them into the cloth's frame when the cloth
simulates in a moving frame (start with the frame's pose at the iteration's start,
``history.before``, end with ``history.now``), then runs the collide kernels over the
particles, the fabric's virtual particles, the faces too large for the smallest sphere or
capsule against the spheres and capsules (clothtool.solver.facepoints picks them,
clothtool.solver.kernels.collide_faces collides each one's deepest point), and last the
cloth's faces against the mesh colliders' vertices and edge samples (clothtool.solver.meshfaces;
not subject to the continuous-collision switch: its contacts catch crossings). Margins are
each collider's thickness plus the cloth material's thickness (metres, converted to scene units).

See clothtool.solver.kernels.collide for what a contact does (push-out averaging, friction,
collision mass scale, continuous collision) and clothtool.solver.kernels.collide_mesh for how
mesh sides are decided. Nothing here allocates per iteration: arrays are sized in
``begin_frame`` and only grow when the colliders do.
"""

from __future__ import annotations

import functools
import operator
import re

import numba
import numpy as np

from clothtool.collision.colliders import ColliderArrays, friction_or
from clothtool.errors import SceneError
from clothtool.solver.facepoints import face_triangles
from clothtool.solver.framefn import FusedCall, copy_lines, stacked
from clothtool.solver.iteration import FramePlan, Iteration
from clothtool.solver.kernels.collide import (
    collide_particles,
    collide_particles_for,
    collide_particles_parallel,
    collide_virtual_for,
)
from clothtool.solver.kernels.collide_faces import collide_faces
from clothtool.solver.kernels.collide_mesh import grid_cell_ranges, grid_fill, grid_layout, triangle_bounds
from clothtool.solver.kernels.collide_mesh_faces import collide_mesh_faces
from clothtool.solver.kernels.collide_pose import (
    convex_shift,
    convex_translation,
    pack_capsules,
    pack_spheres,
    pack_triangles,
    pose_planes,
    pose_points,
    pose_spheres,
)
from clothtool.solver.kernels.collide_shapes import CAPSULE_COLUMNS
from clothtool.solver.meshfaces import collider_owners, sample_spacing
from clothtool.solver.stage import Stage

# What the sphere and capsule records are derived from besides positions and radii.
_SPHERE_LAYOUT = ("sphere_is_collider", "sphere_margin", "sphere_friction", "capsule_spheres", "capsule_margin",
                  "capsule_friction")
# The mesh grid has at most this many cells per triangle.
CELLS_PER_TRIANGLE = 16
I32 = np.int32


def _shared_stacks(start: ColliderArrays, end: ColliderArrays):
    """The prefetched colliders ``start`` and ``end`` are both rows of, or None."""
    if start.source is None or end.source is None or start.source[0] is not end.source[0]:
        return None
    return start.source[0]


def _reuse(array: np.ndarray, shape: tuple) -> np.ndarray:
    """``array`` when it already has ``shape``, else a new zeroed array of its dtype."""
    if array.shape == tuple(shape):
        return array
    return np.zeros(shape, array.dtype)


def _at_least(array: np.ndarray, size: int) -> np.ndarray:
    """A 1-d array of at least ``size`` entries: ``array`` itself unless it must grow."""
    if array.shape[0] >= size:
        return array
    return np.zeros(max(size, 2 * array.shape[0]), array.dtype)


@functools.lru_cache(maxsize=64)
def _names_in(lines: tuple[str, ...]) -> frozenset[str]:
    """The ``{name}`` placeholders of a frame function's lines."""
    return frozenset(re.findall(r"\{(\w+)\}", "\n".join(lines)))


def _in_order(kind: str, names: dict, used: frozenset[str]) -> tuple[str, ...]:
    """The keys of ``names`` (the stage's ``kind`` of frame-function names: its values or its
    kernels) that ``used`` holds, in the order of ``names`` (the frame function's
    parameters); the same every frame of a scene, so worked out once per ``used``."""
    order = _ORDERS.get((kind, used))
    if order is None:
        order = _ORDERS[kind, used] = tuple(name for name in names if name in used)
    return order


_ORDERS: dict[tuple[str, frozenset[str]], tuple[str, ...]] = {}


# the spheres at the frame's start and end (rows of CollideStage.sphere_worlds) and the cloth
# frame's poses at iteration ``it`` (a row of the frame motion's stack), in the lines below
_SPHERES = "{sphere_worlds}[{sphere_rows}[0]], {sphere_worlds}[{sphere_rows}[1]]"
_FRAME = "{frames}[{row}[0] + it]"


@functools.lru_cache(maxsize=None)
def _fused_lines(has_mesh: bool, has_planes: bool, has_convexes: bool, has_virtual: bool, has_faces: bool,
                 mesh_faces: bool) -> tuple[tuple[str, ...], frozenset[str]]:
    """The collide stage's frame-function lines for the collider kinds present, and the
    names they use (the same every frame of a scene: built once, not per frame)."""
    lines = [
        "if it == 0:",
        "    {pose_spheres}(" + _SPHERES + ", " + _FRAME + ", {alpha0}[it], 0, {sphere_start})",
    ]
    if has_mesh:
        lines += ["    if {pose_mesh}[it]:",
                  "        {pose_points}({mesh_world0}, {mesh_world1}, " + _FRAME + ", {alpha0}[it], 0, {mesh_start})"]
    lines += ["else:", *("    " + line for line in copy_lines("{sphere_end}", "{sphere_start}"))]
    if has_mesh:
        lines += ["    if {pose_mesh}[it]:", *("        " + line for line in copy_lines("{mesh_end}", "{mesh_start}"))]
    lines.append("{pose_spheres}(" + _SPHERES + ", " + _FRAME + ", {alpha1}[it], 1, {sphere_end})")
    if has_planes:
        lines.append("{pose_planes}({plane_world0}, {plane_world1}, " + _FRAME + ", {alpha1}[it], 1, {plane_end})")
    lines += [
        "{pack_spheres}({sphere_start}, {sphere_end}, {sphere_colliders}, {sphere_params}, {sphere_data})",
        "{pack_capsules}({sphere_start}, {sphere_end}, {capsule_index}, {capsule_params}, {capsule_data})",
    ]
    if has_convexes:
        lines.append("{convex_shift}({convex_translation}, " + _FRAME + ", {alpha_step}[it], {convex_data})")
    if has_mesh:
        lines += [
            "if {pose_mesh}[it]:",
            "    {pose_points}({mesh_world0}, {mesh_world1}, " + _FRAME + ", {alpha1}[it], 1, {mesh_end})",
            "    {pack_triangles}({mesh_start}, {mesh_end}, {triangles}, {triangle_params}, {triangle_data})",
        ]
    groups = ("({sphere_data}, {capsule_data}, {plane_end}, {convex_offsets}, {convex_data}), "
              "({triangle_data}, {cell_start}, {cell_items}, {cell_ranges}, {grid})")
    lines.append("{collide}(" + groups + ", " + _FRAME + ", prev, {continuous}, {mass_scale}, {meters_per_unit}, cur)")
    if has_virtual:
        lines.append("{collide_virtual}({virtual}, {virtual_weights}, " + groups
                     + ", " + _FRAME + ", prev, {continuous}, {mass_scale}, {meters_per_unit}, cur)")
    if has_faces:
        lines.append("{collide_faces}({faces}, {sphere_data}, {capsule_data}, prev, {mass_scale}, {meters_per_unit}, cur)")
    if mesh_faces:
        lines.append("{collide_mesh_faces}({cloth_triangles}, {owners}, {triangle_data}, {cell_start}, {cell_items}, "
                     "{cell_ranges}, {grid}, " + _FRAME + ", prev, {face_margin}, {mass_scale}, {meters_per_unit}, "
                     "{face_record}, cur)")
    return tuple(lines), _names_in(tuple(lines))


# Every attribute CollideStage.fused_call's values, lines and kernels are made of.
_FUSED_INPUTS = operator.attrgetter(
    "alpha0", "alpha1", "alpha_step", "capsule_data", "capsule_index", "capsule_params", "cell_items",
    "cell_ranges", "cell_start", "cloth_triangles", "continuous", "convex_data", "convex_offsets",
    "convex_translation", "face_margin", "face_record", "faces", "frames", "grid", "kernel", "mass_scale",
    "mesh_end", "mesh_faces", "mesh_start", "mesh_world", "meters_per_unit", "owners", "plane_end", "plane_world",
    "pose_mesh", "row", "sphere_colliders", "sphere_data", "sphere_end", "sphere_params", "sphere_rows", "sphere_start",
    "sphere_worlds", "triangle_data", "triangle_params", "triangles", "virtual", "virtual_kernel", "virtual_weights"
)


class CollideStage(Stage):
    """Collision with ``solver.environment.colliders`` (see the module docstring).

    After ``run`` the arrays the kernels saw stay readable: ``sphere_start``/``sphere_end``
    (s,4) every sphere (capsule ends included) at the iteration's start and end,
    ``plane_end`` (p,4), ``mesh_start``/``mesh_end`` (m,3), in the cloth's frame, radii and
    offsets without margins; and the packed records ``sphere_data``, ``capsule_data``,
    ``convex_data`` and ``triangle_data``.
    """

    name = "collide"

    def __init__(self, solver, faces: bool = True, continuous: bool | None = None):
        """``solver``: the cloth's integrator (model, state, config, environment, history).
        The implicit and explicit integrators pose the colliders with this stage and respond
        their own way (``groups``): they pass ``faces=False`` (no face collision) and ``continuous=True``
        (they have no discrete mode); None takes ``config.continuous_collision``."""
        super().__init__(solver)
        model = solver.model
        material = model.material
        # collider arrays follow the particle state's precision (float64 by default, or float32)
        real = self.real = solver.state.cur.dtype.type
        self.thickness = float(material.thickness) / float(model.units_to_meters)
        self.friction = float(material.friction)  # for colliders that give no friction of their own
        self.mass_scale = real(material.collision_mass_scale)
        self.meters_per_unit = real(model.units_to_meters)
        self.continuous = bool(solver.config.continuous_collision if continuous is None else continuous)
        # thread start-up costs more than it saves on small cloths; results are identical
        self.parallel = model.particle_count >= solver.config.parallel_threshold and numba.config.NUMBA_NUM_THREADS > 1
        self.kernel = collide_particles_parallel if self.parallel else collide_particles  # until begin_frame picks
        fabric = model.fabric
        self.virtual = np.ascontiguousarray(fabric.virtual_particles, I32)
        self.virtual_weights = np.ascontiguousarray(fabric.virtual_particle_weights, real)
        # with continuous collision particles alone collide: faces are collided discretely, and
        # a collider crossing the cloth faster than its width per iteration would push a face
        # out its far side (a sheet swept over a rod thinner than its triangles wraps flat faces
        # round it; tests/physics/test_hard_collision.py); the fabric's own virtual particles do collide
        self.face_collision = bool(solver.config.face_collision) and faces and not self.continuous
        self.faces = np.zeros((0, 3), I32)  # the triangles that collide as faces (see _add_faces)
        # faces against mesh colliders' points: their contacts handle crossings themselves
        self.mesh_faces = bool(solver.config.face_collision) and faces
        self.cloth_triangles = np.ascontiguousarray(model.triangles, I32)
        self._sample_spacing: float | None = None  # see collider_sample_spacing
        self.owners = np.zeros((0, 4), I32)  # see clothtool.solver.meshfaces.collider_owners
        self.face_margin = real(0.0)  # the largest mesh margin
        self.face_record = np.zeros((1, 32), real)
        self.mesh_face_contacts = 0  # cloth triangles corrected by the last iteration
        self._faces_sized = False
        self.frame = np.zeros((8, 3))  # the cloth frame's poses at the iteration's start and end
        self.frame[0:3] = self.frame[4:7] = np.eye(3)
        # world-space samples at the frame's start and end, and per-primitive parameters: the
        # spheres at rows sphere_rows of the time stack sphere_worlds (a bake's prefetched
        # colliders: the same array every frame, only the rows move on; else the stage's own
        # (2, s, 4) of the frame's start and end)
        self.sphere_worlds = np.zeros((2, 0, 4), real)
        self.sphere_rows = np.array([0, 1], np.int64)
        self._sphere_rows = (0, 1)  # the same, as Python integers
        self._stacks = None  # the prefetched colliders the layout was last copied from
        self._copies_each_frame = True  # planes or meshes: copied every frame
        self.sphere_colliders = np.zeros(0, I32)
        self.sphere_params = np.zeros((0, 2), real)  # margin, friction
        self.capsule_index = np.zeros((0, 2), I32)
        self.capsule_params = np.zeros((0, 2), real)
        self.plane_world = (np.zeros((0, 4), real), np.zeros((0, 4), real))
        self.convex_offsets = np.zeros(1, I32)
        self.convex_translation = np.zeros((0, 3), real)  # world translation over the frame
        self.mesh_world = (np.zeros((0, 3), real), np.zeros((0, 3), real))
        self.triangles = np.zeros((0, 3), I32)
        self.triangle_params = np.zeros((0, 2), real)
        # posed for the current iteration (local frame)
        self.sphere_start = np.zeros((0, 4), real)
        self.sphere_end = np.zeros((0, 4), real)
        self.plane_end = np.zeros((0, 4), real)
        self.mesh_start = np.zeros((0, 3), real)
        self.mesh_end = np.zeros((0, 3), real)
        self.sphere_data = np.zeros((0, 9), real)
        self.capsule_data = np.zeros((0, CAPSULE_COLUMNS), real)
        self.convex_data = np.zeros((0, 5), real)
        self.triangle_data = np.zeros((0, 32), real)
        # the mesh grid (world space)
        self.bounds = np.zeros((0, 6), real)
        self.cell_ranges = np.zeros((0, 6), I32)
        self.grid = np.array([0, 0, 0, 1, 1, 1, 1], real)
        self.cell_start = np.zeros(2, I32)
        self.cell_items = np.zeros(1, I32)
        self.mesh_still = False
        self._mesh_packed = False
        # per iteration of the frame (begin_frame): the cloth frame's poses at its start and
        # end (k,8,3), the collider interpolation's alphas, and whether the mesh is posed
        self.frames = np.zeros((1, 8, 3))
        self._frames_moved = True  # self.frames came from a track's poses (not the identity)
        # iteration i's poses are frames[first + i] (FrameStacks), first also as the frame
        # function's argument row (the same array every frame)
        self._first = 0
        self.row = np.zeros(1, np.int64)
        self.alpha0 = self.alpha1 = self.alpha_step = np.zeros(1)
        self._alpha_iterations = 0  # the iteration count the alphas are for
        self._layouts: dict[str, tuple] = {}  # see _same_layout
        self._copied: tuple = (None, None)  # the ColliderArrays the frame's copies were made from
        self.pose_mesh = np.zeros(1, np.bool_)
        self._fused: FusedCall | None = None  # see fused_call
        self._fused_inputs: tuple = ()

    def collider_sample_spacing(self) -> float:
        """The spacing of mesh colliders' edge samples for this cloth (meshfaces.sample_spacing),
        computed when a mesh collider first needs it: scenes without one never do."""
        if self._sample_spacing is None:
            self._sample_spacing = sample_spacing(self.solver.model.rest_pos, self.cloth_triangles)
        return self._sample_spacing

    # ------------------------------------------------------------------ per frame
    def begin_frame(self, plan: FramePlan) -> None:
        colliders = self.solver.environment.colliders
        start = colliders(plan.time)
        end = colliders(plan.end)
        if start is not self._copied[0] or end is not self._copied[1]:  # else: colliders fixed in time
            stacks = _shared_stacks(start, end)
            if stacks is None or stacks is not self._stacks or self._copies_each_frame:
                self._check_same_layout(start, end, plan)
                self._copy_spheres(start, end, stacks)
                self._copy_convexes(start, end)
                self._copy_meshes(start, end)
                self.kernel = self._kernel_for(start)
                self._stacks = stacks
                self._copies_each_frame = start.plane.shape[0] > 0 or start.mesh_points.shape[0] > 0
            else:  # the same prefetched colliders as last frame: their layout stands, the rows move on
                self._set_sphere_rows(start.source[1], end.source[1])
            self._copied = (start, end)
        if self.face_collision and not self._faces_sized:
            self._add_faces(start)
        self._iteration_arrays(plan)

    def _iteration_arrays(self, plan: FramePlan) -> None:
        """The per-iteration values ``pose`` (and the compiled frame function) index."""
        k = plan.iterations
        if self._alpha_iterations != k:  # the same every frame of the same iteration count
            self._alpha_iterations = k
            self.alpha0 = stacked([index / k for index in range(k)], np.float64)
            self.alpha1 = stacked([(index + 1) / k for index in range(k)], np.float64)
            self.alpha_step = self.alpha1 - self.alpha0
        terms = self.solver.frame_terms
        if terms is not None:
            # the cloth frame's poses at each iteration's start and end: rows of the frame
            # motion's stack (the same array every frame of its chain: fused_call's values stand)
            rows = terms.stacks
            self.frames, self._first = rows.pose_pairs, rows.first
        elif self.frames.shape[0] != k or self._frames_moved:
            self.frames = np.zeros((k, 8, 3))  # no track: the identity, the same every frame
            self.frames[:, 0:3] = self.frames[:, 4:7] = np.eye(3)
            self._first = 0
        self._frames_moved = terms is not None
        self.row[0] = self._first
        # a mesh that stands still in the cloth's frame is posed and packed once, not per iteration
        if self.pose_mesh.shape[0] != k:
            self.pose_mesh = np.zeros(k, np.bool_)  # without meshes: False throughout, never set
        if self.mesh_world[0].shape[0]:
            self.pose_mesh[:] = not self.mesh_still
            if self.mesh_still:
                self.pose_mesh[0] = not self._mesh_packed

    def _kernel_for(self, colliders: ColliderArrays):
        """The particle kernel compiled for the collider kinds present (mesh, convex) and the
        continuous setting: a scene of spheres and capsules compiles a fifth of the general one."""
        meshes = colliders.mesh_triangles.shape[0] > 0
        convexes = colliders.convex_plane_offsets.shape[0] > 1
        serial, parallel = collide_particles_for(meshes, convexes, self.continuous)
        # the virtual particles' kernel, kept to the same kinds
        self.virtual_kernel = collide_virtual_for(meshes, convexes, self.continuous)
        return parallel if self.parallel else serial

    def _add_faces(self, colliders: ColliderArrays) -> None:
        """Once, at the first frame: the faces too large for the smallest sphere or capsule
        (its radius plus margins), which collide as faces with the spheres and capsules."""
        self._faces_sized = True
        spheres = np.flatnonzero(colliders.sphere_is_collider)
        ends = colliders.capsule_spheres
        radii = np.concatenate([
            colliders.sphere_radius[spheres] + colliders.sphere_margin[spheres],
            colliders.sphere_radius[ends[:, 0]] + colliders.capsule_margin,
            colliders.sphere_radius[ends[:, 1]] + colliders.capsule_margin,
        ])
        if radii.shape[0] == 0:
            return
        model = self.solver.model
        self.faces = face_triangles(model.rest_pos, model.triangles, float(radii.min()), self.thickness)

    @staticmethod
    def _check_same_layout(start: ColliderArrays, end: ColliderArrays, plan: FramePlan) -> None:
        for name in ("sphere_center", "capsule_spheres", "plane", "convex_plane_offsets", "mesh_points", "mesh_triangles"):
            if getattr(start, name).shape != getattr(end, name).shape:
                raise SceneError(
                    f"colliders of frame {plan.frame}: '{name}' changes shape between t={plan.time:g} s and the "
                    "frame's end; colliders may move and deform but not change their point or primitive counts"
                )

    def _same_layout(self, kind: str, start: ColliderArrays, names: tuple[str, ...]) -> bool:
        """True when ``start``'s arrays ``names`` are the very arrays of the last frame's (a
        bake's prefetched colliders share them across frames): what is derived from them
        alone (margins, frictions, counts) stands. Else remembers them for the next frame."""
        arrays = tuple(getattr(start, name) for name in names)
        last = self._layouts.get(kind)
        if last is not None and all(a is b for a, b in zip(arrays, last)):
            return True
        self._layouts[kind] = arrays
        return False

    def _set_sphere_rows(self, first: int, last: int) -> None:
        self._sphere_rows = (first, last)
        self.sphere_rows[0], self.sphere_rows[1] = first, last

    def _copy_spheres(self, start: ColliderArrays, end: ColliderArrays, stacks) -> None:
        s = start.sphere_center.shape[0]
        if stacks is not None:  # rows of the prefetched stack
            self.sphere_worlds = stacks.sphere_worlds(self.real)
            self._set_sphere_rows(start.source[1], end.source[1])
        else:
            worlds = self.sphere_worlds
            if worlds.shape[1] != s or self._stacks is not None:
                worlds = self.sphere_worlds = np.zeros((2, s, 4), self.real)
            for world, arrays in zip(worlds, (start, end)):
                world[:, :3] = arrays.sphere_center
                world[:, 3] = arrays.sphere_radius
            self._set_sphere_rows(0, 1)
        if self._same_layout("spheres", start, _SPHERE_LAYOUT):
            return
        self.sphere_start = _reuse(self.sphere_start, (s, 4))
        self.sphere_end = _reuse(self.sphere_end, (s, 4))
        colliders = np.flatnonzero(start.sphere_is_collider)
        k = colliders.shape[0]
        self.sphere_colliders = _reuse(self.sphere_colliders, (k,))
        self.sphere_colliders[:] = colliders
        params = self.sphere_params = _reuse(self.sphere_params, (k, 2))
        params[:, 0] = start.sphere_margin[colliders] + self.thickness
        params[:, 1] = friction_or(start.sphere_friction[colliders], self.friction)
        self.sphere_data = _reuse(self.sphere_data, (k, 9))
        c = start.capsule_spheres.shape[0]
        self.capsule_index = _reuse(self.capsule_index, (c, 2))
        self.capsule_index[:] = start.capsule_spheres
        params = self.capsule_params = _reuse(self.capsule_params, (c, 2))
        params[:, 0] = start.capsule_margin + self.thickness
        params[:, 1] = friction_or(start.capsule_friction, self.friction)
        self.capsule_data = _reuse(self.capsule_data, (c, CAPSULE_COLUMNS))

    def _copy_convexes(self, start: ColliderArrays, end: ColliderArrays) -> None:
        p = start.plane.shape[0]
        k = start.convex_plane_offsets.shape[0] - 1
        if p == 0 and k == 0 and self.plane_world[0].shape[0] == 0 and self.convex_data.shape[0] == 0:
            return  # no planes now nor before: nothing to copy
        worlds = tuple(_reuse(w, (p, 4)) for w in self.plane_world)
        worlds[0][:] = start.plane
        worlds[1][:] = end.plane
        self.plane_world = worlds
        self.plane_end = _reuse(self.plane_end, (p, 4))
        self.convex_offsets = _reuse(self.convex_offsets, (k + 1,))
        self.convex_offsets[:] = start.convex_plane_offsets
        self.convex_translation = _reuse(self.convex_translation, (k, 3))
        if k:
            convex_translation(worlds[0], worlds[1], self.convex_offsets, self.convex_translation)
        data = self.convex_data = _reuse(self.convex_data, (k, 5))
        data[:, 0] = start.convex_margin + self.thickness
        data[:, 1] = friction_or(start.convex_friction, self.friction)

    def _copy_meshes(self, start: ColliderArrays, end: ColliderArrays) -> None:
        m = start.mesh_points.shape[0]
        t = start.mesh_triangles.shape[0]
        if m == 0 and t == 0 and self.mesh_world[0].shape[0] == 0 and self.triangles.shape[0] == 0:
            # no meshes now nor before: every mesh array is empty already (as below, cheaper)
            self.mesh_still = self.solver.history is None
            self._mesh_packed = self._mesh_packed and self.mesh_still
            return
        same = (
            self.mesh_world[0].shape == (m, 3)
            and np.array_equal(self.mesh_world[0], start.mesh_points)
            and np.array_equal(self.mesh_world[1], end.mesh_points)
            and np.array_equal(self.triangles, start.mesh_triangles)
        )
        # a mesh that stands still in the cloth's frame is posed and packed once, not per iteration
        self.mesh_still = self.solver.history is None and np.array_equal(start.mesh_points, end.mesh_points)
        if same and self.mesh_still and self._mesh_packed:
            return
        self._mesh_packed = False
        worlds = tuple(_reuse(w, (m, 3)) for w in self.mesh_world)
        worlds[0][:] = start.mesh_points
        worlds[1][:] = end.mesh_points
        self.mesh_world = worlds
        self.mesh_start = _reuse(self.mesh_start, (m, 3))
        self.mesh_end = _reuse(self.mesh_end, (m, 3))
        self.triangles = _reuse(self.triangles, (t, 3))
        self.triangles[:] = start.mesh_triangles
        params = self.triangle_params = _reuse(self.triangle_params, (t, 2))
        params[:, 0] = start.mesh_margin[start.triangle_mesh] + self.thickness
        params[:, 1] = friction_or(start.mesh_friction[start.triangle_mesh], self.friction)
        self.triangle_data = _reuse(self.triangle_data, (t, 32))
        self.bounds = _reuse(self.bounds, (t, 6))
        self.cell_ranges = _reuse(self.cell_ranges, (t, 6))
        if t == 0:
            return
        # float32 rounding of world coordinates: grow the boxes by a few ulps of the extent
        extent = max(float(np.abs(worlds[0]).max()), float(np.abs(worlds[1]).max()), 1e-6)
        margins = np.ascontiguousarray(params[:, 0])
        triangle_bounds(worlds[0], worlds[1], self.triangles, margins, self.real(extent * 1e-6), self.bounds)
        cells = grid_layout(self.bounds, float(CELLS_PER_TRIANGLE * t), self.grid)
        entries = grid_cell_ranges(self.bounds, self.grid, self.cell_ranges)
        self.cell_start = _at_least(self.cell_start, cells + 1)
        self.cell_items = _at_least(self.cell_items, entries)
        grid_fill(self.cell_ranges, self.grid, self.cell_start, self.cell_items)
        if self.mesh_faces:
            self.owners = collider_owners(self.triangles, worlds[0], self.collider_sample_spacing())
            self.face_margin = self.real(params[:, 0].max())

    # ------------------------------------------------------------------ per iteration
    def pose(self, iteration: Iteration) -> None:
        """Pose the colliders for ``iteration``: start at alpha0 with the frame's pose at the
        iteration's start, end at alpha1 with its pose at the end. ``fused_call`` is the same
        in the compiled frame function's terms."""
        i = iteration.index
        frame = self.frame = self.frames[self._first + i]
        alpha0, alpha1 = self.alpha0[i], self.alpha1[i]
        # kinds the scene lacks are skipped (zero-length arrays): their kernels never compile
        pose_mesh = self.pose_mesh[i]
        if i == 0:
            pose_spheres(*self._sphere_pair(), frame, alpha0, 0, self.sphere_start)
            if pose_mesh:
                pose_points(*self.mesh_world, frame, alpha0, 0, self.mesh_start)
        else:  # the last iteration's end is this one's start
            np.copyto(self.sphere_start, self.sphere_end)
            if pose_mesh:
                np.copyto(self.mesh_start, self.mesh_end)
        pose_spheres(*self._sphere_pair(), frame, alpha1, 1, self.sphere_end)
        if self.plane_end.shape[0]:
            pose_planes(*self.plane_world, frame, alpha1, 1, self.plane_end)
        pack_spheres(self.sphere_start, self.sphere_end, self.sphere_colliders, self.sphere_params, self.sphere_data)
        pack_capsules(self.sphere_start, self.sphere_end, self.capsule_index, self.capsule_params, self.capsule_data)
        if self.convex_data.shape[0]:
            convex_shift(self.convex_translation, frame, self.alpha_step[i], self.convex_data)
        if pose_mesh:
            pose_points(*self.mesh_world, frame, alpha1, 1, self.mesh_end)
            pack_triangles(self.mesh_start, self.mesh_end, self.triangles, self.triangle_params, self.triangle_data)
            self._mesh_packed = self.mesh_still

    def fused_call(self) -> FusedCall:
        # every attribute the call is made of: while each is the same object as when the last
        # call was made (a usual frame: begin_frame refills the arrays in place), it stands
        inputs = _FUSED_INPUTS(self)
        fused = self._fused
        if fused is not None and all(map(operator.is_, inputs, self._fused_inputs)):
            return fused
        self._fused, self._fused_inputs = self._make_fused_call(), inputs
        return self._fused

    def _make_fused_call(self) -> FusedCall:
        lines, used = _fused_lines(
            self.mesh_world[0].shape[0] > 0, self.plane_end.shape[0] > 0, self.convex_data.shape[0] > 0,
            self.virtual.shape[0] > 0, self.faces.shape[0] > 0, self.mesh_faces and self.triangle_data.shape[0] > 0,
        )
        values = self._fused_values()
        args = {name: values[name] for name in _in_order("values", values, used)}
        kernels = {
            "pose_spheres": pose_spheres, "pose_points": pose_points, "pose_planes": pose_planes,
            "pack_spheres": pack_spheres, "pack_capsules": pack_capsules, "convex_shift": convex_shift,
            "pack_triangles": pack_triangles, "collide": self.kernel, "collide_virtual": self.virtual_kernel,
            "collide_mesh_faces": collide_mesh_faces, "collide_faces": collide_faces,
        }
        return FusedCall(lines, args, {name: kernels[name] for name in _in_order("kernels", kernels, used)})

    def _fused_values(self) -> dict:
        """Every array and scalar the frame function's lines may name, by name, in the order of
        the frame function's parameters."""
        return {
            "frames": self.frames, "row": self.row, "alpha0": self.alpha0, "alpha1": self.alpha1, "alpha_step": self.alpha_step,
            "pose_mesh": self.pose_mesh, "sphere_worlds": self.sphere_worlds, "sphere_rows": self.sphere_rows,
            "sphere_start": self.sphere_start, "sphere_end": self.sphere_end, "mesh_world0": self.mesh_world[0],
            "mesh_world1": self.mesh_world[1], "mesh_start": self.mesh_start, "mesh_end": self.mesh_end,
            "plane_world0": self.plane_world[0], "plane_world1": self.plane_world[1], "plane_end": self.plane_end,
            "sphere_colliders": self.sphere_colliders, "sphere_params": self.sphere_params,
            "sphere_data": self.sphere_data, "capsule_index": self.capsule_index,
            "capsule_params": self.capsule_params, "capsule_data": self.capsule_data,
            "convex_translation": self.convex_translation, "convex_offsets": self.convex_offsets,
            "convex_data": self.convex_data, "triangles": self.triangles, "triangle_params": self.triangle_params,
            "triangle_data": self.triangle_data, "cell_start": self.cell_start, "cell_items": self.cell_items,
            "cell_ranges": self.cell_ranges, "grid": self.grid, "continuous": self.continuous,
            "mass_scale": self.mass_scale, "meters_per_unit": self.meters_per_unit, "virtual": self.virtual,
            "virtual_weights": self.virtual_weights, "cloth_triangles": self.cloth_triangles, "owners": self.owners,
            "face_margin": self.face_margin, "face_record": self.face_record, "faces": self.faces,
        }

    def _sphere_pair(self) -> tuple[np.ndarray, np.ndarray]:
        """The spheres at the frame's start and end: (s, 4) centres and radii."""
        first, last = self._sphere_rows
        return self.sphere_worlds[first], self.sphere_worlds[last]

    def end_fused_frame(self) -> None:
        self.frame = self.frames[self._first + self._alpha_iterations - 1]
        if self.pose_mesh[0]:
            self._mesh_packed = self.mesh_still

    def groups(self, empty: bool = False) -> tuple[tuple, tuple]:
        """The kernels' (shapes, mesh) argument groups; zero-length views when ``empty``."""
        if empty:
            shapes = (
                self.sphere_data[:0], self.capsule_data[:0], self.plane_end[:0], self.convex_offsets[:1], self.convex_data[:0]
            )
            return shapes, (self.triangle_data[:0], self.cell_start, self.cell_items, self.cell_ranges[:0], self.grid)
        shapes = (self.sphere_data, self.capsule_data, self.plane_end, self.convex_offsets, self.convex_data)
        return shapes, (self.triangle_data, self.cell_start, self.cell_items, self.cell_ranges, self.grid)

    def warm_up(self) -> None:
        state = self.solver.state
        shapes, mesh = self.groups(empty=True)
        # the kernel begin_frame will pick: a scene's collider kinds are the same at every time
        colliders = self.solver.environment.colliders(0.0)
        self.kernel = self._kernel_for(colliders)
        self.kernel(
            shapes, mesh, self.frame, state.prev[:0], self.continuous, self.mass_scale, self.meters_per_unit, state.cur[:0]
        )
        # as in run(): a big kernel, compiled only for fabrics with virtual particles
        if self.virtual.shape[0]:
            self.virtual_kernel(
                self.virtual[:0], self.virtual_weights, shapes, mesh, self.frame, state.prev[:0], self.continuous, self.mass_scale,
                self.meters_per_unit, state.cur[:0],
            )
        if self.face_collision and colliders.has_spheres_or_capsules:  # begin_frame may pick faces
            collide_faces(self.faces[:0], shapes[0], shapes[1], state.prev[:0], self.mass_scale, self.meters_per_unit,
                          state.cur[:0])
        if self.mesh_faces and colliders.mesh_triangles.shape[0]:
            collide_mesh_faces(
                self.cloth_triangles[:0], self.owners[:0], *mesh, self.frame, state.prev[:0], self.face_margin,
                self.mass_scale, self.meters_per_unit, self.face_record, state.cur[:0],
            )
        self.warm_up_motion()

    def warm_up_motion(self) -> None:
        """Compile the kernels that pose and pack the colliders and grid the meshes (the
        part of ``warm_up`` the implicit and explicit integrators use)."""
        colliders = self.solver.environment.colliders(0.0)
        spheres, points, planes = self.sphere_start[:0], self.mesh_start[:0], self.plane_end[:0]
        pose_spheres(spheres, spheres, self.frame, 0.0, 0, spheres)
        pack_spheres(spheres, spheres, self.sphere_colliders[:0], self.sphere_params[:0], self.sphere_data[:0])
        pack_capsules(spheres, spheres, self.capsule_index[:0], self.capsule_params[:0], self.capsule_data[:0])
        if colliders.plane.shape[0]:
            pose_planes(planes, planes, self.frame, 0.0, 0, planes)
            convex_translation(planes, planes, self.convex_offsets[:1], self.convex_translation[:0])
            convex_shift(self.convex_translation[:0], self.frame, 0.0, self.convex_data[:0])
        if colliders.mesh_points.shape[0] == 0:
            return
        pose_points(points, points, self.frame, 0.0, 0, points)
        triangles, bounds = self.triangles[:0], self.bounds[:0]
        pack_triangles(points, points, triangles, self.triangle_params[:0], self.triangle_data[:0])
        # the mesh grid is built (begin_frame) only when there are mesh triangles
        if colliders.mesh_triangles.shape[0] == 0:
            return
        triangle_bounds(points, points, triangles, self.triangle_params[:0, 0].copy(), self.real(0.0), bounds)
        grid = self.grid.copy()
        grid_layout(bounds, 1.0, grid)
        grid_cell_ranges(bounds, grid, self.cell_ranges[:0])
        grid_fill(self.cell_ranges[:0], grid, self.cell_start.copy(), self.cell_items[:0])

    def run(self, iteration: Iteration) -> None:
        state = self.solver.state
        self.pose(iteration)
        shapes, mesh = self.groups()
        self.kernel(shapes, mesh, self.frame, state.prev, self.continuous, self.mass_scale, self.meters_per_unit, state.cur)
        if self.virtual.shape[0]:
            self.virtual_kernel(
                self.virtual, self.virtual_weights, shapes, mesh, self.frame, state.prev, self.continuous, self.mass_scale,
                self.meters_per_unit, state.cur,
            )
        if self.faces.shape[0]:
            collide_faces(self.faces, shapes[0], shapes[1], state.prev, self.mass_scale, self.meters_per_unit, state.cur)
        if self.mesh_faces and self.triangle_data.shape[0]:
            self.mesh_face_contacts = collide_mesh_faces(
                self.cloth_triangles, self.owners, *mesh, self.frame, state.prev, self.face_margin, self.mass_scale,
                self.meters_per_unit, self.face_record, state.cur,
            )
