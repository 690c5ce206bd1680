"""Colliders from the prims of a USD stage, sampled with pxr.

* ``Sphere``, ``Capsule``, ``Cube`` and ``Plane`` prims become analytic colliders whose track
  is the prim's local-to-world transform (ancestors included) sampled at every frame and at
  every authored transform sample in between. Each sample is decomposed into translation,
  rotation and scale and the track slerps between them: USD interpolates ``xformOp:transform``
  matrices component by component, which shrinks a turning body between samples.
* ``Mesh`` prims with time-sampled ``points`` are deforming mesh colliders (points in the
  prim's own space, moved by its transform track).
* Meshes skinned with UsdSkel are skinned by pxr (``UsdSkel.SkinningQuery``) at every frame;
  their points are stored in world space (no track). Blend shapes are refused.

A body referenced (or payloaded) from a layer whose authored ``metersPerUnit`` or ``upAxis``
differ from the stage's is scaled and turned into the stage's units below the referencing
prim's own transform (``unit_root``); USD composes such a reference as it is, in the wrong
size. A referencing prim with a ``unitsResolve`` op (Omniverse's metrics assembler) is
taken as converted already.

Times: a stage's time codes are frames at ``timeCodesPerSecond``; tracks are in seconds.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from clothtool.errors import SceneError
from clothtool.scene.colliders import Collider
from clothtool.scene.tracks import Track, decompose_matrix

ANALYTIC_TYPES = ("Sphere", "Capsule", "Cube", "Plane")
THICKNESS_ATTR = "clothtool:thickness"
FRICTION_ATTR = "clothtool:friction"


class ShotClock:
    """The time codes at which bodies are sampled (frames ``first``..``last``, both included)."""

    def __init__(self, time_codes_per_second: float, first: int, last: int):
        self.tcps = float(time_codes_per_second)
        self.first = int(first)
        self.last = int(last)

    @property
    def frames(self) -> np.ndarray:
        return np.arange(self.first, self.last + 1, dtype=np.float64)


def open_stage(path: Path):
    """The composed stage of ``path``, its layers noted as inputs; SceneError when USD cannot open it."""
    from pxr import Usd

    import clothtool.usd_env  # noqa: F401  (before pxr: how crate files are read)
    from clothtool.inputs import note_input
    from clothtool.usd_env import quiet_stderr

    with quiet_stderr():
        try:
            stage = Usd.Stage.Open(str(path))
        except Exception as exc:  # pxr raises Tf.ErrorException for unreadable layers
            raise SceneError(f"{path}: USD cannot open the stage ({' '.join(str(exc).split())[:160]}); check the file") from None
    if stage is None:
        raise SceneError(f"{path}: USD cannot open the stage; check the file")
    for layer in stage.GetUsedLayers():
        if layer.realPath:
            note_input(layer.realPath)
    return stage


def stage_units(stage, source: str) -> tuple[float, str]:
    """(metersPerUnit, upAxis) of the stage, which its bodies' coordinates are written in."""
    from pxr import UsdGeom

    mpu, up_axis = float(UsdGeom.GetStageMetersPerUnit(stage)), str(UsdGeom.GetStageUpAxis(stage))
    if not (np.isfinite(mpu) and mpu > 0):
        raise SceneError(f"{source}: stage metadata metersPerUnit = {mpu:g}; give a positive size (0.01 for centimetres)")
    if up_axis not in ("Y", "Z"):
        raise SceneError(f"{source}: stage upAxis is {up_axis!r}; clothtool reads Y-up or Z-up stages, re-export with one")
    return mpu, up_axis


@dataclasses.dataclass(frozen=True)
class UnitRoot:
    """A prim that references (or payloads) a layer written in other units than the stage's:
    its content (the referenced prims, their transforms and points) is scaled by ``scale`` and
    turned by ``rotation`` below the prim's own transform, as Omniverse's metrics assembler
    does with an ``xformOp:scale:unitsResolve`` op appended to the referencing prim."""

    path: str
    scale: float
    rotation: np.ndarray  # (3,3)
    xformable: object

    def correction(self, time_code) -> np.ndarray:
        """4x4 (column-vector convention) taking the uncorrected world to the corrected one at
        ``time_code``: the prim's world transform, the unit change, and back."""
        world = _matrix(self.xformable, time_code)
        change = np.eye(4)
        change[:3, :3] = self.scale * self.rotation
        return world @ change @ np.linalg.inv(world)


UNITS_RESOLVED_OPS = ("xformOp:scale:unitsResolve", "xformOp:rotateX:unitsResolve")


def unit_root(prim, stage_units: tuple[float, str], source: str) -> UnitRoot | None:
    """The nearest prim at or above ``prim`` that references a layer whose authored
    metersPerUnit or upAxis differ from the stage's (None: none does, or the referencing prim
    already carries a ``unitsResolve`` op that converts it)."""
    from pxr import Usd, UsdGeom

    from clothtool.mesh.units import unit_change

    walk = prim
    while walk and not walk.IsPseudoRoot():
        query_filter = Usd.PrimCompositionQuery.Filter()
        query_filter.arcTypeFilter = Usd.PrimCompositionQuery.ArcTypeFilter.ReferenceOrPayload
        query_filter.dependencyTypeFilter = Usd.PrimCompositionQuery.DependencyTypeFilter.Direct
        for arc in Usd.PrimCompositionQuery(walk, query_filter).GetCompositionArcs():
            layer = arc.GetTargetNode().layerStack.identifier.rootLayer
            info = layer.pseudoRoot
            mpu = float(info.GetInfo(UsdGeom.Tokens.metersPerUnit)) if info.HasInfo(UsdGeom.Tokens.metersPerUnit) else stage_units[0]
            up = str(info.GetInfo(UsdGeom.Tokens.upAxis)) if info.HasInfo(UsdGeom.Tokens.upAxis) else stage_units[1]
            where = f"{source}: prim {walk.GetPath()} references {layer.identifier.rsplit('/', 1)[-1]}"
            if not (np.isfinite(mpu) and mpu > 0) or up not in ("Y", "Z"):
                raise SceneError(f"{where}, whose metersPerUnit {mpu:g} / upAxis {up!r} clothtool cannot read; fix the layer's metadata")
            if (mpu, up) == stage_units:
                continue
            ops = {op.GetOpName() for op in UsdGeom.Xformable(walk).GetOrderedXformOps()}
            if ops & set(UNITS_RESOLVED_OPS):
                return None  # the referencing prim converts it already
            scale, rotation = unit_change(mpu, up, *stage_units)
            return UnitRoot(str(walk.GetPath()), scale, rotation, UsdGeom.Xformable(walk))
        walk = walk.GetParent()
    return None


def shot_clock(stage, fps: float, start: int, end: int) -> ShotClock:
    """The stage's time codes that cover scene frames ``start``..``end`` at ``fps`` (the stage
    may run at another rate: its time codes are converted through seconds)."""
    tcps = float(stage.GetTimeCodesPerSecond())
    first = int(np.floor(start / fps * tcps))
    return ShotClock(tcps, first, max(int(np.ceil(end / fps * tcps)), first + 1))


def with_preroll(body: Collider, clock: ShotClock, fps: float, start: int, preroll: int) -> Collider:
    """A deforming body blends from its rest pose into its first pose over the ``preroll``
    frames before ``start``, so a garment modelled in the bind pose settles onto it."""
    if not preroll or body.deform_points is None:
        return body
    return dataclasses.replace(body, blend=((start - preroll) / fps * clock.tcps, clock.first))


def _matrix(xformable, time_code) -> np.ndarray:
    """4x4 local-to-world at ``time_code``, column-vector convention (pxr's is row-vector)."""
    return np.array(xformable.ComputeLocalToWorldTransform(time_code), np.float64).T


def _transform_times(prim, clock: ShotClock) -> np.ndarray:
    """Frames plus the authored transform samples of the prim and its ancestors within them."""
    from pxr import UsdGeom

    times = set(clock.frames.tolist())
    walk = prim
    while walk and not walk.IsPseudoRoot():
        xformable = UsdGeom.Xformable(walk)
        if xformable:
            times.update(t for t in xformable.GetTimeSamples() if clock.first <= t <= clock.last)
        walk = walk.GetParent()
    return np.array(sorted(times), np.float64)


def transform_track(prim, clock: ShotClock, source: str, units: UnitRoot | None = None) -> Track:
    """The prim's local-to-world transform as a slerped track (see module docstring), in the
    stage's units (``units``: the prim's content comes from a layer in other units)."""
    from pxr import Usd, UsdGeom

    xformable = UsdGeom.Xformable(prim)
    times = _transform_times(prim, clock)
    translations, rotations, scales = [], [], []
    for time in times:
        where = f"{source}: prim {prim.GetPath()} at time code {time:g}"
        matrix = _matrix(xformable, Usd.TimeCode(time))
        if units is not None:
            matrix = units.correction(Usd.TimeCode(time)) @ matrix
        t, q, s = decompose_matrix(matrix, where)
        translations.append(t)
        rotations.append(q)
        scales.append(s)
    if len(times) > 1 and np.ptp(translations, axis=0).max() == 0 and np.ptp(rotations, axis=0).max() == 0 \
            and np.ptp(scales, axis=0).max() == 0:
        times, translations, rotations, scales = times[:1], translations[:1], rotations[:1], scales[:1]
    return Track(str(prim.GetPath()), times / clock.tcps, np.asarray(translations), np.asarray(rotations), np.asarray(scales))


def _number(prim, name: str, default: float, source: str) -> float:
    attr = prim.GetAttribute(name)
    value = attr.Get() if attr and attr.HasAuthoredValue() else default
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not np.isfinite(value) or value < 0:
        raise SceneError(f"{source}: prim {prim.GetPath()} attribute '{name}' = {value!r}; give a non-negative number")
    return float(value)


def _static(prim, name: str, source: str):
    """An attribute that must not be animated (radius, size, axis): its value at Default or
    its only value; animated ones are refused."""
    from pxr import Usd

    attr = prim.GetAttribute(name)
    if attr.GetNumTimeSamples() > 1:
        raise SceneError(
            f"{source}: prim {prim.GetPath()} animates '{name}'; clothtool takes shapes of fixed size "
            "(animate the transform's scale instead)"
        )
    value = attr.Get(Usd.TimeCode.EarliestTime())
    return value


_AXES = {"X": 0, "Y": 1, "Z": 2}


def _analytic(prim, type_name: str, source: str) -> dict:
    """Local geometry of an analytic prim as Collider fields."""
    none3, none1, no_planes = np.zeros((0, 3)), np.zeros(0), np.zeros((0, 4))
    if type_name == "Sphere":
        radius = float(_static(prim, "radius", source))
        if not radius > 0:
            raise SceneError(f"{source}: prim {prim.GetPath()} has radius {radius:g}; give a positive radius")
        return dict(kind="sphere", centers=np.zeros((1, 3)), radii=np.array([radius]), planes=no_planes)
    if type_name == "Capsule":
        radius, height = float(_static(prim, "radius", source)), float(_static(prim, "height", source))
        axis = np.zeros(3)
        axis[_AXES[str(_static(prim, "axis", source))]] = 1.0
        if not (radius > 0 and height > 0):
            raise SceneError(f"{source}: prim {prim.GetPath()} has radius {radius:g}, height {height:g}; both must be positive")
        ends = np.stack([-0.5 * height * axis, 0.5 * height * axis])
        return dict(kind="capsule", centers=ends, radii=np.array([radius, radius]), planes=no_planes)
    if type_name == "Cube":
        half = 0.5 * float(_static(prim, "size", source))
        if not half > 0:
            raise SceneError(f"{source}: prim {prim.GetPath()} has size {2 * half:g}; give a positive size")
        planes = [(*(sign * np.eye(3)[axis]), half) for axis in range(3) for sign in (1.0, -1.0)]
        return dict(kind="convex", centers=none3, radii=none1, planes=np.asarray(planes))
    normal = np.zeros(3)  # Plane: the axis is the normal, through the local origin
    normal[_AXES[str(_static(prim, "axis", source))]] = 1.0
    return dict(kind="plane", centers=none3, radii=none1, planes=np.array([[*normal, 0.0]]))


COLLIDER_KEEPS_TOPOLOGY = "a collider keeps its topology: export a fixed-topology mesh (or a point cache of the same mesh)"


def fixed_topology(mesh, source: str, keeps: str = COLLIDER_KEEPS_TOPOLOGY, points: bool = False) -> dict[str, np.ndarray]:
    """{'faceVertexCounts', 'faceVertexIndices'}: the mesh's faces, refusing time samples that
    change them (and with ``points``, the number of points; colliders check that at every frame
    they sample); ``keeps`` says why and how to fix it."""
    from pxr import Usd

    path = mesh.GetPath()
    values = {}
    for attr in (mesh.GetFaceVertexCountsAttr(), mesh.GetFaceVertexIndicesAttr()):
        samples = attr.GetTimeSamples()
        first = np.asarray(attr.Get(Usd.TimeCode(samples[0]) if samples else Usd.TimeCode.Default()) or [], np.int64)
        for time in samples[1:]:
            if not np.array_equal(np.asarray(attr.Get(Usd.TimeCode(time)), np.int64), first):
                raise SceneError(f"{source}: prim {path} changes '{attr.GetName()}' at time code {time:g}; {keeps}")
        values[attr.GetName()] = first
    attr = mesh.GetPointsAttr()
    sizes = {time: len(attr.Get(Usd.TimeCode(time)) or []) for time in (attr.GetTimeSamples() if points else [])}
    if len(set(sizes.values())) > 1:
        time = next(t for t, n in sizes.items() if n != next(iter(sizes.values())))
        raise SceneError(
            f"{source}: prim {path} has {sizes[time]} points at time code {time:g} but "
            f"{next(iter(sizes.values()))} at its first sample; {keeps}"
        )
    return values


def _topology(mesh, source: str):
    """Face counts and indices (refusing time samples that change them) and triangles."""
    from clothtool.mesh import topology

    path = mesh.GetPath()
    values = fixed_topology(mesh, source)
    counts, indices = values["faceVertexCounts"].astype(np.int32), values["faceVertexIndices"].astype(np.int32)
    if int(counts.sum()) != indices.size or counts.size == 0:
        raise SceneError(f"{source}: prim {path} faceVertexCounts and faceVertexIndices do not match; re-export the mesh")
    triangles, _ = topology.triangulate(counts, indices)
    return counts, indices, triangles.astype(np.int32)


def _points(attr, time, count: int | None, source: str, path) -> np.ndarray:
    value = attr.Get(time)
    points = np.asarray(value if value is not None else [], np.float64).reshape(-1, 3)
    if count is not None and points.shape[0] != count:
        raise SceneError(
            f"{source}: prim {path} has {points.shape[0]} points at time code {time.GetValue():g} but {count} "
            "elsewhere; a collider keeps its topology: export a fixed-topology mesh"
        )
    if not np.isfinite(points).all():
        raise SceneError(f"{source}: prim {path} has NaN points at time code {time.GetValue():g}; fix the export")
    return points


def _mesh(prim, clock: ShotClock, source: str) -> dict:
    """A mesh prim: static or point-cached points in its own space."""
    from pxr import Usd, UsdGeom

    mesh = UsdGeom.Mesh(prim)
    counts, indices, triangles = _topology(mesh, source)
    attr = mesh.GetPointsAttr()
    rest = _points(attr, Usd.TimeCode.EarliestTime(), None, source, prim.GetPath())
    if triangles.size and triangles.max() >= rest.shape[0]:
        raise SceneError(f"{source}: prim {prim.GetPath()} has faces referencing missing points; re-export the mesh")
    fields = dict(kind="mesh", mesh_points=rest, mesh_triangles=triangles, mesh_faces=(counts, indices))
    if attr.GetNumTimeSamples() > 1:
        frames = clock.frames
        fields["deform_frames"] = frames
        fields["deform_points"] = np.stack(
            [_points(attr, Usd.TimeCode(f), rest.shape[0], source, prim.GetPath()) for f in frames]
        )
    return fields


def skinning_targets(stage, source: str) -> dict:
    """Prim path -> (skeleton query, skinning query, skeleton) of every mesh a UsdSkel
    skeleton skins (pxr's warnings about broken skeletons are held back: the collider that
    uses one reports it in one line)."""
    from pxr import Usd, UsdSkel

    from clothtool.usd_env import quiet_stderr

    with quiet_stderr():
        return _skinning_targets(stage, Usd, UsdSkel)


def _skinning_targets(stage, Usd, UsdSkel) -> dict:
    cache = UsdSkel.Cache()
    targets = {}
    for prim in stage.Traverse():
        if not prim.IsA(UsdSkel.Root):
            continue
        root = UsdSkel.Root(prim)
        cache.Populate(root, Usd.PrimDefaultPredicate)
        for binding in cache.ComputeSkelBindings(root, Usd.PrimDefaultPredicate):
            skeleton = binding.GetSkeleton()
            query = cache.GetSkelQuery(skeleton)
            for target in binding.GetSkinningTargets():
                targets[str(target.GetPrim().GetPath())] = (query, target, skeleton)
    return targets


def _skinned(prim, skinning, clock: ShotClock, source: str, units: UnitRoot | None) -> dict:
    """A UsdSkel-skinned mesh, skinned by pxr at every frame, in world space; its rest points
    are the bind pose (the points through the geomBindTransform)."""
    from pxr import Gf, Usd, UsdGeom, Vt

    query, target, skeleton = skinning
    path = prim.GetPath()
    if not query or not query.HasBindPose():
        raise SceneError(
            f"{source}: prim {path} is bound to skeleton {skeleton.GetPath()} which cannot be evaluated "
            "(check its joints, bindTransforms and restTransforms); fix the skeleton export"
        )
    if target.HasBlendShapes():
        raise SceneError(
            f"{source}: prim {path} has UsdSkel blend shapes, which clothtool does not apply; bake the body to a "
            "point cache (time-sampled points) in your DCC"
        )
    mesh = UsdGeom.Mesh(prim)
    counts, indices, triangles = _topology(mesh, source)
    points_attr = mesh.GetPointsAttr()
    rest_local = _points(points_attr, Usd.TimeCode.EarliestTime(), None, source, path)
    bind = np.array(target.GetGeomBindTransform(Usd.TimeCode.EarliestTime()), np.float64)
    rest = rest_local @ bind[:3, :3] + bind[3, :3]
    if units is not None:  # the bind pose is in the skeleton's space: converted as at the first frame
        rest = _moved(rest, units.correction(Usd.TimeCode(clock.first)))
    skeleton_xformable = UsdGeom.Xformable(skeleton.GetPrim())
    frames = clock.frames
    deformed = []
    for frame in frames:
        time = Usd.TimeCode(frame)
        transforms = query.ComputeSkinningTransforms(time)
        if transforms is None or len(transforms) == 0:
            raise SceneError(
                f"{source}: prim {path}: skeleton {skeleton.GetPath()} gives no joint transforms at time code "
                f"{frame:g}; check its animation source and joints"
            )
        local = _points(points_attr, time, rest.shape[0], source, path)
        if target.IsRigidlyDeformed():
            matrix = Gf.Matrix4d(1.0)
            if not target.ComputeSkinnedTransform(transforms, matrix, time):
                raise SceneError(f"{source}: prim {path}: UsdSkel could not skin it at time code {frame:g}; check its joint indices")
            m = np.array(matrix, np.float64)
            skinned = local @ m[:3, :3] + m[3, :3]
        else:
            values = Vt.Vec3fArray.FromNumpy(local.astype(np.float32))
            if not target.ComputeSkinnedPoints(transforms, values, time):
                raise SceneError(
                    f"{source}: prim {path}: UsdSkel could not skin it at time code {frame:g} (skinning method "
                    f"{target.GetSkinningMethod()!s}, joint indices/weights); check the skin binding"
                )
            skinned = np.asarray(values, np.float64)
        to_world = np.array(skeleton_xformable.ComputeLocalToWorldTransform(time), np.float64)
        world = skinned @ to_world[:3, :3] + to_world[3, :3]
        deformed.append(world if units is None else _moved(world, units.correction(time)))
    return dict(kind="mesh", mesh_points=rest, mesh_triangles=triangles, mesh_faces=(counts, indices),
                deform_frames=frames, deform_points=np.stack(deformed), rest_points=rest)


def _moved(points: np.ndarray, matrix: np.ndarray) -> np.ndarray:
    """(m,3) points through a 4x4 column-vector-convention matrix."""
    return points @ matrix[:3, :3].T + matrix[:3, 3]


def body_collider(prim, name: str, clock: ShotClock, skinning, source: str, units: UnitRoot | None = None) -> Collider:
    """The collider of one prim (see module docstring); ``skinning`` is its entry of
    ``skinning_targets`` or None; ``units`` its ``unit_root`` when it comes from a layer in
    other units than the stage's (its thickness is then in that layer's units too)."""
    type_name = str(prim.GetTypeName())
    thickness = _number(prim, THICKNESS_ATTR, 0.0, source) * (1.0 if units is None else units.scale)
    friction = _number(prim, FRICTION_ATTR, float("nan"), source) if prim.GetAttribute(FRICTION_ATTR) else float("nan")
    common = dict(name=name, thickness=thickness, friction=friction, fps=clock.tcps)
    none3, none1, no_planes = np.zeros((0, 3)), np.zeros(0), np.zeros((0, 4))
    if skinning is not None:
        from clothtool.usd_env import quiet_stderr

        if type_name != "Mesh":
            raise SceneError(
                f"{source}: prim {prim.GetPath()} is a {type_name or 'typeless prim'} skinned by UsdSkel, and clothtool "
                "skins Mesh prims only; export it as a skinned Mesh or a point cache, or parent it under an animated xform"
            )

        with quiet_stderr():  # pxr warns on stderr; what matters is raised in one line
            fields = _skinned(prim, skinning, clock, source, units)
        return Collider(track=None, centers=none3, radii=none1, planes=no_planes, **fields, **common)
    track = transform_track(prim, clock, source, units)
    if type_name in ANALYTIC_TYPES:
        return Collider(track=track, **_analytic(prim, type_name, source), **common)
    if type_name == "Mesh":
        return Collider(track=track, centers=none3, radii=none1, planes=no_planes, **_mesh(prim, clock, source), **common)
    raise SceneError(
        f"{source}: prim {prim.GetPath()} is a {type_name or 'typeless prim'}, which clothtool cannot collide with; "
        f"mark a {', '.join(ANALYTIC_TYPES)} or Mesh prim as collider instead"
    )
