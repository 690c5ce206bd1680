"""Colliders from scene tables, evaluated into world-space ColliderArrays at any time.

Each ``[collider.NAME]`` has a ``kind`` (sphere, capsule, plane, convex, mesh), geometry in
its own local coordinates, an optional ``track`` that moves it (local -> world, with
scale), a ``thickness`` (margin, scene units) and a ``friction`` coefficient. Mesh colliders
come from any mesh file ``clothtool cook`` reads (read by the scene's loaders,
``clothtool.scene.loaders``) and may deform with per-frame points from an NPZ file (arrays
``frame`` (k,) and ``points`` (k, m, 3), in the mesh file's units). In a USD file ``prim``
picks the mesh; a prim that moves (time-sampled points or transform) or is skinned
with UsdSkel is read as a USD stage's bodies are (``clothtool.scene.usdbodies``) over the
scene's frames. A mesh file that says its units (USD's metersPerUnit and upAxis, glTF) is
brought into the scene's units (``clothtool.scene.bodyunits``).
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from clothtool.collision.colliders import ColliderArrays, ColliderInfo
from clothtool.errors import ClothtoolError, SceneError
from clothtool.inputs import note_input
from clothtool.scene.tracks import Track, quat_to_matrices, sample_tracks

KINDS = ("sphere", "capsule", "plane", "convex", "mesh")
COMMON_KEYS = ("kind", "track", "thickness", "friction")
KIND_KEYS = {
    "sphere": ("center", "radius"),
    "capsule": ("start", "end", "radius", "radii"),
    "plane": ("point", "normal"),
    "convex": ("planes", "box"),
    "mesh": ("mesh", "deform", "prim"),
}


@dataclasses.dataclass(frozen=True, eq=False)
class Collider:
    """One collider in its local frame (see module docstring)."""

    name: str
    kind: str
    track: Track | None
    thickness: float
    friction: float
    centers: np.ndarray  # (s,3) sphere centres (sphere: 1, capsule: 2)
    radii: np.ndarray  # (s,)
    planes: np.ndarray  # (p,4) n, d with solid side n.x < d
    mesh_points: np.ndarray | None = None  # (m,3)
    mesh_triangles: np.ndarray | None = None  # (t,3)
    mesh_faces: tuple[np.ndarray, np.ndarray] | None = None  # render topology (counts, indices)
    deform_frames: np.ndarray | None = None  # (k,) frame numbers of the deformation samples
    deform_points: np.ndarray | None = None  # (k,m,3)
    fps: float = 24.0
    # the pose garments were modelled on (a skinned body's bind pose), local frame; None: the
    # points at the first deformation sample
    rest_points: np.ndarray | None = None  # (m,3)
    # pre-roll: from frame blend[0] to blend[1] the points blend from the rest pose to the
    # first deformation sample (smoothstep), so a garment modelled in the bind pose settles
    blend: tuple[float, float] | None = None

    def matrix(self, time: float) -> np.ndarray:
        """4x4 local -> world (column-vector convention)."""
        return np.eye(4) if self.track is None else self.track.sample(time).matrix()

    def is_animated(self) -> bool:
        return (self.track is not None and not self.track.is_static) or self.deform_points is not None

    def local_points(self, time: float) -> np.ndarray:
        if self.deform_points is None:
            return self.mesh_points
        frame = time * self.fps
        frames = self.deform_frames
        if self.blend is not None and frame < self.blend[1]:
            first, last = self.blend
            u = min(max((frame - first) / (last - first), 0.0), 1.0)
            s = u * u * (3.0 - 2.0 * u)
            return self.rest_pose() + s * (self.deform_points[0] - self.rest_pose())
        i = int(np.clip(np.searchsorted(frames, frame, side="right") - 1, 0, frames.shape[0] - 1))
        if i == frames.shape[0] - 1 or frame <= frames[0]:
            return self.deform_points[0 if frame <= frames[0] else i]
        u = (frame - frames[i]) / (frames[i + 1] - frames[i])
        return self.deform_points[i] + u * (self.deform_points[i + 1] - self.deform_points[i])

    def rest_pose(self) -> np.ndarray:
        """(m,3) local points of the rest pose (see ``rest_points``)."""
        if self.rest_points is not None:
            return self.rest_points
        return self.mesh_points if self.deform_points is None else self.deform_points[0]

    def shape_matrix(self) -> np.ndarray:
        """4x4 from the cache's canonical shape frame to the collider's local frame: spheres
        at the origin, capsules along +X centred on the origin, planes with normal +Y through
        the origin; convexes and meshes keep their own coordinates. Made once (a capsule's
        took ~33 us, and a bake writing colliders asks every frame); read-only."""
        made = self.__dict__.get("_shape_matrix")
        if made is None:
            made = self._make_shape_matrix()
            made.flags.writeable = False
            self.__dict__["_shape_matrix"] = made  # a frozen dataclass: its own cache slot, as Track's samples
        return made

    def _make_shape_matrix(self) -> np.ndarray:
        m = np.eye(4)
        if self.kind == "sphere":
            m[:3, 3] = self.centers[0]
        elif self.kind == "capsule":
            m[:3, :3] = _rotation_from_to(np.array([1.0, 0.0, 0.0]), self.centers[1] - self.centers[0])
            m[:3, 3] = self.centers.mean(axis=0)
        elif self.kind == "plane":
            normal = self.planes[0, :3]
            m[:3, :3] = _rotation_from_to(np.array([0.0, 1.0, 0.0]), normal)
            m[:3, 3] = normal * self.planes[0, 3]
        return m

    def info(self) -> ColliderInfo:
        if self.kind == "sphere":
            params = {"radius": float(self.radii[0])}
        elif self.kind == "capsule":
            params = {"radius0": float(self.radii[0]), "radius1": float(self.radii[1]),
                      "length": float(np.linalg.norm(self.centers[1] - self.centers[0]))}
        elif self.kind == "convex":
            params = {"planes": self.planes.astype(np.float64)}
        else:
            params = {}
        counts, indices = self.mesh_faces if self.mesh_faces is not None else (None, None)
        return ColliderInfo(self.name, self.kind, params, counts, indices,
                            None if self.mesh_points is None else self.mesh_points.astype(np.float32))


def _rotation_from_to(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The smallest rotation taking direction a to direction b."""
    a = a / np.linalg.norm(a)
    b = b / np.linalg.norm(b)
    v = np.cross(a, b)
    c = float(a @ b)
    if c < -1.0 + 1e-12:  # opposite: half a turn about any axis perpendicular to a
        axis = np.cross(a, [1.0, 0.0, 0.0] if abs(a[0]) < 0.9 else [0.0, 1.0, 0.0])
        axis /= np.linalg.norm(axis)
        return 2.0 * np.outer(axis, axis) - np.eye(3)
    skew = np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])
    return np.eye(3) + skew + skew @ skew / (1.0 + c)


class SceneColliders:
    """All colliders of a scene; ``at(time)`` gives world ColliderArrays (memoised per time;
    ``prefetch`` evaluates a bake's frame times together)."""

    def __init__(self, colliders: tuple[Collider, ...]):
        self.colliders = colliders
        self._cache: dict[float, ColliderArrays] = {}
        self._prefetched: _ColliderSamples | None = None
        # colliders with no track (or a one-key track) and no deformation are the same at every
        # time: ``at`` gives one ColliderArrays for all, and a cloth's collide stage, seeing
        # the very arrays of its last frame, copies nothing (a track of several equal keys is
        # left out: interpolating equal keys need not give their bits)
        self._fixed = all(
            c.deform_points is None and (c.track is None or c.track.times.shape[0] == 1) for c in colliders
        )
        self._fixed_arrays: ColliderArrays | None = None

    def __len__(self) -> int:
        return len(self.colliders)

    def infos(self) -> tuple[ColliderInfo, ...]:
        return tuple(c.info() for c in self.colliders)

    def xforms(self, time: float) -> tuple[np.ndarray, ...]:
        """Per collider, the 4x4 world matrix in the row-vector convention caches use. At a
        prefetched time the track's matrix is the prefetch's (the bits of ``matrix(time)``,
        which made one for a single time anew: ~35 us a collider a frame)."""
        samples = self._prefetched
        row = None if samples is None else samples.rows.get(time)
        if row is None:
            return tuple((c.matrix(time) @ c.shape_matrix()).T.copy() for c in self.colliders)
        matrices = samples.track_matrices
        return tuple((matrices[id(c.track)][row] @ c.shape_matrix()).T.copy() for c in self.colliders)

    def deformed_points(self, time: float) -> tuple[np.ndarray | None, ...]:
        return tuple(
            c.local_points(time).astype(np.float32) if c.deform_points is not None else None for c in self.colliders
        )

    def prefetch(self, times) -> None:
        """Evaluate the colliders at all of ``times`` at once (a bake's frame times): every
        track sampled in one vectorised call, spheres and capsules placed for all times
        together. ``at`` then finds these times (mesh points are placed when asked, so that
        a long bake of a big body does not hold every frame's points)."""
        self._prefetched = _ColliderSamples(self.colliders, np.asarray(times, np.float64), prefetch_tracks=True)
        self._cache.clear()

    def at(self, time: float) -> ColliderArrays:
        if self._fixed_arrays is not None:
            return self._fixed_arrays
        arrays = self._cache.get(time)
        if arrays is None:
            if len(self._cache) > 4:  # a bake asks for the start and end of each frame
                self._cache.clear()
            samples = self._prefetched
            row = None if samples is None else samples.rows.get(time)
            if row is None:  # the same code for one time: the same bits as a prefetched time
                samples, row = _ColliderSamples(self.colliders, np.array([float(time)])), 0
            arrays = self._cache[time] = samples.arrays(row)
        if self._fixed:
            self._fixed_arrays = arrays
        return arrays

    def rest_mesh(self, time: float, names) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The mesh colliders in their rest pose, placed by their tracks at ``time``: world
        points (m,3) and triangles (t,3) numbered as in ``at(time)``'s mesh arrays, and a
        (t,) mask of the triangles of the colliders ``names``."""
        points, triangles, mask, count = [], [], [], 0
        for collider in self.colliders:
            if collider.kind != "mesh":
                continue
            m = collider.matrix(time)
            rest = collider.rest_pose()
            points.append(rest @ m[:3, :3].T + m[:3, 3])
            triangles.append(collider.mesh_triangles + count)
            mask.append(np.full(collider.mesh_triangles.shape[0], collider.name in names))
            count += rest.shape[0]
        if not points:
            return np.zeros((0, 3)), np.zeros((0, 3), np.int32), np.zeros(0, bool)
        return np.concatenate(points), np.concatenate(triangles).astype(np.int32), np.concatenate(mask)


def _f32(values, shape) -> np.ndarray:
    return np.asarray(values, np.float32).reshape(shape)


def _track_matrices(colliders: tuple[Collider, ...], times: np.ndarray, prefetch_tracks: bool) -> dict[int, np.ndarray]:
    """(T,4,4) local -> world matrices at ``times`` of each of the colliders' tracks (by the
    track's id; None's: the identity), each as ``collider.matrix`` gives it. The tracks are
    sampled together (sample_tracks) and, with ``prefetch_tracks``, keep their samples."""
    tracks = list({id(c.track): c.track for c in colliders if c.track is not None}.values())
    samples = sample_tracks(tracks, times)
    # every track's rotation matrices in one call (row by row: the bits of one call each)
    turns = quat_to_matrices(np.concatenate([rotations for _, rotations, _ in samples])) if samples else None
    matrices = {}
    for n, (track, (translations, rotations, scales)) in enumerate(zip(tracks, samples)):
        if prefetch_tracks:
            track.prefetch(times, (translations, rotations, scales))
        m = np.zeros((times.shape[0], 4, 4))
        m[:] = np.eye(4)
        m[:, :3, :3] = turns[n * times.shape[0] : (n + 1) * times.shape[0]] * scales[:, None, :]
        m[:, :3, 3] = translations
        matrices[id(track)] = m
    identity = np.zeros((times.shape[0], 4, 4))
    identity[:] = np.eye(4)
    matrices[id(None)] = identity
    return matrices


class _ColliderSamples:
    """The scene's colliders at several times: what stays the same at every time (margins,
    frictions, counts, triangles) once, spheres, capsule ends and planes as (T, ...) stacks;
    ``arrays(row)`` is the ColliderArrays at ``times[row]``. Every value is computed with the
    operations a single time would use (matrix by vector, row by row), so one time and many
    give the same bits."""

    def __init__(self, colliders: tuple[Collider, ...], times: np.ndarray, prefetch_tracks: bool = False):
        self.colliders = colliders
        self.times = times
        self.rows = {float(t): row for row, t in enumerate(times)}
        count = times.shape[0]
        tracks = _track_matrices(colliders, times, prefetch_tracks)  # colliders sharing a track share its matrices
        self.track_matrices = tracks  # for SceneColliders.xforms
        centers, radii, s_margin, s_friction, s_collider = [], [], [], [], []
        capsules, c_margin, c_friction = [], [], []
        planes, offsets, v_margin, v_friction = [], [0], [], []
        self.meshes: list[tuple[Collider, np.ndarray]] = []  # (collider, (T,4,4) matrices)
        triangles, tri_mesh, m_margin, m_friction = [], [], [], []
        point_count = 0
        for collider in colliders:
            m = tracks[id(collider.track)]
            linear, translation = m[:, :3, :3], m[:, :3, 3]
            if collider.kind in ("sphere", "capsule"):
                scale = np.cbrt(np.abs(np.linalg.det(linear)))
                first = len(centers)
                for c, r in zip(collider.centers, collider.radii):
                    centers.append(np.matmul(linear, c) + translation)
                    radii.append(r * scale)
                    s_margin.append(collider.thickness)
                    s_friction.append(collider.friction)
                    s_collider.append(collider.kind == "sphere")
                if collider.kind == "capsule":
                    capsules.append((first, first + 1))
                    c_margin.append(collider.thickness)
                    c_friction.append(collider.friction)
            elif collider.kind in ("plane", "convex"):
                planes.append(self._planes(collider, linear, translation))
                offsets.append(offsets[-1] + collider.planes.shape[0])
                v_margin.append(collider.thickness)
                v_friction.append(collider.friction)
            else:
                self.meshes.append((collider, m))
                triangles.append(collider.mesh_triangles + point_count)
                tri_mesh.append(np.full(collider.mesh_triangles.shape[0], len(m_margin), np.int32))
                point_count += collider.rest_pose().shape[0]
                m_margin.append(collider.thickness)
                m_friction.append(collider.friction)
        # (T, s, 3) and (T, s): time first, so that each time's rows are contiguous
        self.sphere_center = _f32(np.stack(centers, axis=1) if centers else np.zeros((count, 0, 3)), (count, -1, 3))
        self.sphere_radius = _f32(np.stack(radii, axis=1) if radii else np.zeros((count, 0)), (count, -1))
        self.plane = _f32(np.concatenate(planes, axis=1) if planes else np.zeros((count, 0, 4)), (count, -1, 4))
        self.fixed = dict(
            sphere_margin=_f32(s_margin, -1),
            sphere_friction=_f32(s_friction, -1),
            sphere_is_collider=np.asarray(s_collider, bool),
            capsule_spheres=np.asarray(capsules, np.int32).reshape(-1, 2),
            capsule_margin=_f32(c_margin, -1),
            capsule_friction=_f32(c_friction, -1),
            convex_plane_offsets=np.asarray(offsets, np.int32),
            convex_margin=_f32(v_margin, -1),
            convex_friction=_f32(v_friction, -1),
            mesh_triangles=np.concatenate(triangles).astype(np.int32) if triangles else np.zeros((0, 3), np.int32),
            triangle_mesh=np.concatenate(tri_mesh) if tri_mesh else np.zeros(0, np.int32),
            mesh_margin=_f32(m_margin, -1),
            mesh_friction=_f32(m_friction, -1),
        )
        self._no_mesh_points = np.zeros((0, 3), np.float32)
        self._sphere_worlds: dict[np.dtype, np.ndarray] = {}

    @staticmethod
    def _planes(collider: Collider, linear: np.ndarray, translation: np.ndarray) -> np.ndarray:
        """(T, p, 4) world planes (unit normal, offset); time by time, as one time would."""
        result = np.empty((linear.shape[0], collider.planes.shape[0], 4))
        for row in range(linear.shape[0]):
            normal_matrix = np.linalg.inv(linear[row]).T
            for index, plane in enumerate(collider.planes):
                n = normal_matrix @ plane[:3]
                length = np.linalg.norm(n)
                point_on = linear[row] @ (plane[:3] * plane[3]) + translation[row]  # local n.x = d at x = d n
                n = n / length
                result[row, index] = (*n, float(n @ point_on))
        return result

    def _mesh_points(self, row: int) -> np.ndarray:
        if not self.meshes:
            return self._no_mesh_points
        time = float(self.times[row])
        points = []
        for collider, m in self.meshes:
            points.append(collider.local_points(time) @ m[row, :3, :3].T + m[row, :3, 3])
        return _f32(np.concatenate(points), (-1, 3))

    def arrays(self, row: int) -> ColliderArrays:
        return ColliderArrays.of({
            **self.fixed,
            "sphere_center": self.sphere_center[row],
            "sphere_radius": self.sphere_radius[row],
            "plane": self.plane[row],
            "mesh_points": self._mesh_points(row),
            "source": (self, row),
        })

    def sphere_worlds(self, dtype) -> np.ndarray:
        """(T, s, 4) every time's sphere centres and radii in ``dtype`` (made once a dtype): a
        cloth's collide stage poses the spheres from its rows (CollideStage.sphere_rows)."""
        dtype = np.dtype(dtype)
        worlds = self._sphere_worlds.get(dtype)
        if worlds is None:
            worlds = self._sphere_worlds[dtype] = np.empty((*self.sphere_radius.shape, 4), dtype)
            worlds[..., :3] = self.sphere_center
            worlds[..., 3] = self.sphere_radius
        return worlds


# ------------------------------------------------------------------------ loading
def _box_planes(ctx, table: dict, where: str) -> np.ndarray:
    box = ctx.check_keys(table, ("center", "size"), f"{where}.box")
    center = ctx.vector(box, "center", f"{where}.box", default=[0.0, 0.0, 0.0])
    size = ctx.vector(box, "size", f"{where}.box")
    if np.any(size <= 0):
        ctx.fail(f"{where}.box", f"key 'size' = {size.tolist()} must be positive in every axis")
    planes = []
    for axis in range(3):
        for sign in (1.0, -1.0):
            n = np.zeros(3)
            n[axis] = sign
            planes.append((*n, float(n @ center + size[axis] / 2)))
    # the box's solid is inside all six planes: n.x < d for each outward normal n
    return np.asarray(planes)


def _has_interior(planes: np.ndarray) -> bool:
    """Whether the intersection of the solid sides n.x < d has an interior (a small LP)."""
    from scipy.optimize import linprog

    # maximise t subject to n_i . x + t <= d_i, |x| bounded
    a = np.hstack([planes[:, :3], np.ones((planes.shape[0], 1))])
    result = linprog(
        c=[0, 0, 0, -1], A_ub=a, b_ub=planes[:, 3], bounds=[(-1e6, 1e6)] * 3 + [(None, 1.0)], method="highs"
    )
    return bool(result.status == 0 and -result.fun > 1e-9)


def _planes(ctx, table: dict, where: str) -> np.ndarray:
    if ("planes" in table) == ("box" in table):
        ctx.fail(where, "a convex needs either 'planes' = [[nx, ny, nz, d], ...] or 'box' = { center, size }")
    if "box" in table:
        return _box_planes(ctx, table["box"], where)
    raw = table["planes"]
    planes = np.asarray(raw, np.float64) if isinstance(raw, list) else np.zeros(0)
    if planes.ndim != 2 or planes.shape[1] != 4 or planes.shape[0] == 0 or not np.isfinite(planes).all():
        ctx.fail(where, "key 'planes' must be a list of [nx, ny, nz, d] (solid side n.x < d)")
    lengths = np.linalg.norm(planes[:, :3], axis=1)
    if np.any(lengths < 1e-9):
        ctx.fail(where, f"plane {int(np.argmin(lengths))} has a zero normal")
    planes = planes / lengths[:, None]
    if not _has_interior(planes):
        ctx.fail(where, "the planes enclose no volume (the convex has no interior); check the normals point outwards")
    return planes


def _mesh(ctx, table: dict, where: str, shot: Shot):
    from clothtool.mesh import topology
    from clothtool.mesh.units import unit_change

    path = ctx.base / str(table["mesh"])
    try:
        mesh = ctx.loaders.read_mesh(path, table.get("prim"))
    except ClothtoolError as exc:
        ctx.fail(where, f"mesh: {exc}")
    triangles, _ = topology.triangulate(mesh.face_vertex_counts, mesh.face_vertex_indices)
    if triangles.size and (triangles.min() < 0 or triangles.max() >= mesh.vertex_count):
        ctx.fail(where, f"mesh {path.name} has faces referencing missing vertices; re-export it")
    if not np.isfinite(mesh.vertex_pos).all():
        ctx.fail(where, f"mesh {path.name} has NaN coordinates; fix it in your DCC")
    frames = points = None
    if "deform" in table:
        deform = ctx.base / str(table["deform"])
        note_input(deform)
        try:
            with np.load(deform) as data:
                frames = np.asarray(data["frame"], np.float64)
                points = np.asarray(data["points"], np.float64)
        except (OSError, KeyError, ValueError) as exc:
            ctx.fail(where, f"deform file {deform.name}: needs arrays 'frame' (k,) and 'points' (k, m, 3) ({exc})")
        if points.shape != (frames.shape[0], mesh.vertex_count, 3):
            ctx.fail(where, f"deform file {deform.name}: 'points' has shape {points.shape}, expected ({frames.shape[0]}, {mesh.vertex_count}, 3)")
        if np.any(np.diff(frames) <= 0) or not np.isfinite(points).all():
            ctx.fail(where, f"deform file {deform.name}: frames must increase and points be finite")
    # a file that says its units is read in the scene's; one that does not is taken as written
    scale, rotation = unit_change(mesh.meters_per_unit or shot.meters_per_unit, mesh.up_axis or shot.up_axis,
                                  shot.meters_per_unit, shot.up_axis)
    vertex_pos = scale * (mesh.vertex_pos.astype(np.float64) @ rotation.T)
    points = None if points is None else scale * (points @ rotation.T)
    return (
        vertex_pos,
        triangles.astype(np.int32),
        (mesh.face_vertex_counts.astype(np.int32), mesh.face_vertex_indices.astype(np.int32)),
        frames,
        points,
    )


def _moving_usd_body(ctx, name: str, table: dict, where: str, shot: Shot) -> Collider | None:
    """The collider of ``table``'s USD ``prim`` when it moves or is skinned (sampled over the
    scene's frames as a USD stage's bodies are); None for a still prim, which reads as any mesh."""
    from clothtool.scene.bodyunits import body_in_scene_units
    from clothtool.scene.usdbodies import body_collider, open_stage, shot_clock, skinning_targets, stage_units, with_preroll

    path, prim_path = ctx.base / str(table["mesh"]), table["prim"]
    if not isinstance(prim_path, str) or not prim_path.startswith("/"):
        ctx.fail(where, f"key 'prim' = {prim_path!r}; give the mesh prim's path, like \"/Body\"")
    if path.suffix.lower() not in (".usd", ".usda", ".usdc"):
        return None  # read_mesh refuses a prim outside USD files, in one line
    try:
        stage = open_stage(path)
    except ClothtoolError as exc:
        ctx.fail(where, f"mesh: {exc}")
    prim = stage.GetPrimAtPath(prim_path)
    if not prim or prim.GetTypeName() != "Mesh":
        return None  # read_mesh names the missing prim or the prim that is no mesh
    source = str(path)
    try:
        clock = shot_clock(stage, shot.fps, shot.start, shot.end)
        body = body_collider(prim, name, clock, skinning_targets(stage, source).get(prim_path), source)
        body = body_in_scene_units(body, *stage_units(stage, source), shot.meters_per_unit, shot.up_axis)
    except ClothtoolError as exc:
        ctx.fail(where, f"mesh: {exc}")
    if body.deform_points is None and (body.track is None or body.track.is_static):
        return None  # a still body: the mesh as read_mesh places it, and 'track' may move it
    for key in ("track", "deform"):
        if key in table:
            ctx.fail(where, f"key '{key}': prim {prim_path} of {path.name} moves by its own animation; drop '{key}'")
    return with_preroll(body, clock, shot.fps, shot.start, shot.preroll)


def _collider(ctx, name: str, table: dict, tracks: dict[str, Track], shot: Shot) -> Collider:
    fps = shot.fps
    where = f"collider.{name}"
    if not isinstance(table, dict):
        ctx.fail(where, "must be a table with a 'kind'")
    kind = table.get("kind")
    if kind not in KINDS:
        ctx.fail(where, f"key 'kind' = {kind!r}; use one of {', '.join(KINDS)}")
    ctx.check_keys(table, COMMON_KEYS + KIND_KEYS[kind], where)
    track = ctx.track(table, where, tracks)
    thickness = ctx.number(table, "thickness", where, default=0.0)
    # no friction given: the colliding cloth's material friction applies (NaN marks that)
    friction = ctx.number(table, "friction", where) if "friction" in table else float("nan")
    if thickness < 0 or friction < 0:
        ctx.fail(where, "keys 'thickness' and 'friction' must not be negative")
    none3, none1, no_planes = np.zeros((0, 3)), np.zeros(0), np.zeros((0, 4))
    common = dict(name=name, kind=kind, track=track, thickness=thickness, friction=friction, fps=fps)
    if kind == "sphere":
        radius = ctx.number(table, "radius", where)
        if not radius > 0:
            ctx.fail(where, f"key 'radius' = {radius:g} must be positive")
        center = ctx.vector(table, "center", where, default=[0.0, 0.0, 0.0])
        return Collider(centers=center[None], radii=np.array([radius]), planes=no_planes, **common)
    if kind == "capsule":
        if ("radius" in table) == ("radii" in table):
            ctx.fail(where, "give 'radius' (both ends) or 'radii' = [r0, r1] (a tapered capsule)")
        radii = (
            np.full(2, ctx.number(table, "radius", where)) if "radius" in table else ctx.vector(table, "radii", where, size=2)
        )
        if np.any(radii <= 0):
            ctx.fail(where, f"capsule radii {radii.tolist()} must be positive")
        start, end = ctx.vector(table, "start", where), ctx.vector(table, "end", where)
        length = np.linalg.norm(end - start)
        if length <= abs(radii[1] - radii[0]) or length < 1e-9:
            ctx.fail(where, "degenerate capsule: its ends coincide (or one sphere swallows the other); use a sphere")
        return Collider(centers=np.stack([start, end]), radii=radii, planes=no_planes, **common)
    if kind == "plane":
        normal = ctx.vector(table, "normal", where, default=[0.0, 1.0, 0.0])
        if np.linalg.norm(normal) < 1e-9:
            ctx.fail(where, "key 'normal' must not be zero")
        normal = normal / np.linalg.norm(normal)
        point = ctx.vector(table, "point", where, default=[0.0, 0.0, 0.0])
        return Collider(centers=none3, radii=none1, planes=np.array([[*normal, normal @ point]]), **common)
    if kind == "convex":
        return Collider(centers=none3, radii=none1, planes=_planes(ctx, table, where), **common)
    if "mesh" not in table:
        ctx.fail(where, "a mesh collider needs 'mesh' = a mesh file")
    if "prim" in table:
        body = _moving_usd_body(ctx, name, table, where, shot)
        if body is not None:
            return dataclasses.replace(body, thickness=thickness, friction=friction)
    points, triangles, faces, frames, deform = _mesh(ctx, table, where, shot)
    return Collider(centers=none3, radii=none1, planes=no_planes, mesh_points=points, mesh_triangles=triangles,
                    mesh_faces=faces, deform_frames=frames, deform_points=deform, **common)


@dataclasses.dataclass(frozen=True)
class Shot:
    """The scene's frames (at ``fps``, pre-roll included) that moving USD bodies are sampled
    over, and the scene's units that bodies are read in."""

    fps: float
    start: int
    end: int
    preroll: int = 0
    meters_per_unit: float = 1.0
    up_axis: str = "Y"


def load_colliders(ctx, tables: dict, tracks: dict[str, Track], shot: Shot) -> SceneColliders:
    if not isinstance(tables, dict):
        raise SceneError(f"{ctx.path}: [collider] must hold tables like [collider.NAME]")
    return SceneColliders(tuple(_collider(ctx, name, table, tracks, shot) for name, table in tables.items()))


def collider_paths(tables: dict, base: Path) -> list[Path]:
    """Files the colliders read (for error messages and provenance)."""
    return [base / str(t[k]) for t in tables.values() if isinstance(t, dict) for k in ("mesh", "deform") if k in t]
