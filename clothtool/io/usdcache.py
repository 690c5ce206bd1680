"""USD caches (``.usdc``, ``.usd``, ``.usda``): one UsdGeom.Mesh per cloth, points time-sampled.

The layout is specified in ``formats/cache-usd/v1.md``. Frames are written through the Sdf
layer API (no composed stage while baking: each frame costs a copy, not a recomposition), and
a crate layer is saved every ``options.save_every`` frames: a crate save appends the new
samples to the file and drops them from memory, so memory stays flat however long the bake.
A ``.usda`` layer is text and is saved once, when the writer closes (memory grows with the
frame count). The reader has the API of ``clothtool.io.h5cache.CacheReader``.
"""

from __future__ import annotations

import contextlib
import json
import os
import re
from collections.abc import Callable
from pathlib import Path

import numpy as np

import clothtool.usd_env  # noqa: F401  (before pxr: how crate files are read)
from pxr import Gf, Kind, Sdf, Tf, Usd, UsdGeom, Vt, Work

from clothtool import __version__
from clothtool.errors import ClothtoolError, FormatError
from clothtool.io.atomic import check_output_path, temporary_sibling, write_error
from clothtool.io import cache_units as units
from clothtool.io.cache import CacheHeader, CacheOptions, ClothTopology, ColliderInfo, FrameData
from clothtool.io.cache_common import (
    CacheReader,
    FORMAT_NAME,
    FORMAT_VERSION,
    StreamedCacheWriter,
    as_points,
    deformed_collider_points,
    format_cache_summary,
    points_extent,
    scalar_params_json,
    writes_colliders,
)
from clothtool.io.heap import keep_freed_memory
from clothtool.io.vt_points import vec3f_array

__all__ = ["UsdCacheWriter", "UsdCacheReader", "read_usd_cache", "format_cache_summary"]

ROOT = Sdf.Path("/Bake")
CLOTH_ROOT = ROOT.AppendChild("Cloth")
COLLIDER_ROOT = ROOT.AppendChild("Colliders")
_PRIMVAR_PREFIX = "primvars:clothtool:"
_STATS_PREFIX = "clothtool:stats:"


def _temporary_name(path: Path) -> Path:
    # Sdf picks the file format from the extension: the temporary name must keep it.
    return temporary_sibling(path, keep_suffix=True)


def _layer_args(path: Path) -> dict:
    # ".usd" follows USD_DEFAULT_FILE_FORMAT unless told: pin crate (binary, incremental saves).
    return {"format": "usdc"} if path.suffix.lower() == ".usd" else {}


# ---------------------------------------------------------------------------------------------
# Collider display geometry.


def tapered_capsule_mesh(radius0: float, radius1: float, length: float, segments: int = 24, rings: int = 6):
    """Counts, indices, points of the convex hull of two spheres at x = -length/2 and +length/2.

    The profile runs from the pole of sphere 0 (-X) to the pole of sphere 1 (+X); the two caps
    meet the cone where its side is tangent to both spheres.
    """
    c0, c1 = -0.5 * length, 0.5 * length
    # Outward normal angle (from +X) of the tangent line; one sphere inside the other: no cone.
    cos_t = np.clip((radius0 - radius1) / length, -1.0, 1.0) if length > 0 else np.sign(radius0 - radius1)
    theta_t = float(np.arccos(cos_t))
    theta0 = np.linspace(np.pi, theta_t, rings + 1)
    theta1 = np.linspace(theta_t, 0.0, rings + 1)
    x = np.concatenate([c0 + radius0 * np.cos(theta0), c1 + radius1 * np.cos(theta1)])
    rho = np.concatenate([radius0 * np.sin(theta0), radius1 * np.sin(theta1)])
    x, rho = x[1:-1], rho[1:-1]  # the poles become single points
    phi = np.linspace(0.0, 2 * np.pi, segments, endpoint=False)
    ring_points = np.stack(
        [np.repeat(x, segments), np.outer(rho, np.cos(phi)).ravel(), np.outer(rho, np.sin(phi)).ravel()], axis=1
    )
    pole0, pole1 = len(ring_points), len(ring_points) + 1
    points = np.vstack([ring_points, [[c0 - radius0, 0, 0], [c1 + radius1, 0, 0]]]).astype(np.float32)
    faces = []
    j = np.arange(segments)
    jn = (j + 1) % segments
    faces += [[pole0, jn[s], j[s]] for s in range(segments)]
    for r in range(len(x) - 1):
        a, b = r * segments, (r + 1) * segments
        faces += [[a + j[s], a + jn[s], b + jn[s], b + j[s]] for s in range(segments)]
    last = (len(x) - 1) * segments
    faces += [[pole1, last + j[s], last + jn[s]] for s in range(segments)]
    counts = np.array([len(face) for face in faces], np.int32)
    indices = np.array([i for face in faces for i in face], np.int32)
    return counts, indices, points


def convex_hull_mesh(planes: np.ndarray):
    """Counts, indices, points of the solid {x : n.x <= d for every plane (n, d)}, or None.

    The scene's convention (clothtool.scene.colliders): outward normals, solid side n.x < d.
    None when the planes bound no finite, non-empty solid (then only the planes are stored).
    """
    from scipy.optimize import linprog
    from scipy.spatial import ConvexHull, HalfspaceIntersection, QhullError

    planes = np.asarray(planes, np.float64)
    norms = np.linalg.norm(planes[:, :3], axis=1)
    if planes.shape[0] < 4 or np.any(norms == 0):
        return None
    # Chebyshev centre: the interior point deepest inside every plane (Qhull needs one).
    cost = np.zeros(4)
    cost[3] = -1.0
    lp = linprog(cost, A_ub=np.column_stack([planes[:, :3], norms]), b_ub=planes[:, 3], bounds=[(None, None)] * 3 + [(0, None)])
    if lp.status != 0 or lp.x[3] <= 1e-9:
        return None
    try:
        # Qhull's half-spaces are [A, b] with A x + b <= 0.
        halfspaces = np.column_stack([planes[:, :3], -planes[:, 3]])
        with np.errstate(divide="ignore", invalid="ignore"):  # an open solid has corners at infinity
            corners = HalfspaceIntersection(halfspaces, lp.x[:3]).intersections
        if not np.isfinite(corners).all():
            return None
        hull = ConvexHull(corners)
    except (QhullError, ValueError):
        return None
    triangles = hull.simplices.copy()
    # Qhull does not orient its facets: make every normal point away from the centre.
    a, b, c = (corners[triangles[:, i]] for i in range(3))
    outward = np.einsum("ij,ij->i", np.cross(b - a, c - a), a - lp.x[:3]) > 0
    triangles[~outward] = triangles[~outward][:, ::-1]
    counts = np.full(len(triangles), 3, np.int32)
    return counts, triangles.astype(np.int32).ravel(), corners.astype(np.float32)


# ---------------------------------------------------------------------------------------------
# The writer.


class UsdLayerWriter(StreamedCacheWriter):
    """What every USD writer shares: one Sdf layer in the temporary file, saved every
    ``save_every`` frames (crate) or once at the end (text), and given up after a failed save."""

    def __init__(self, path: Path, options: CacheOptions = CacheOptions()):
        path = check_output_path(path)
        super().__init__(path, _temporary_name(path))
        self._crate = path.suffix.lower() in (".usdc", ".usd")
        # Text layers rewrite the whole file on every save: save them once, at the end.
        self._save_every = int(options.save_every) if self._crate else 0
        self._layer = None
        keep_freed_memory()  # each save frees the samples of ``save_every`` frames

    def _write_whole_frame(self, frame: int, write: Callable[[float], None]) -> None:
        """``write(time)`` puts the frame's samples into the layer (in one change block); then
        the frame is counted, and a crate layer is saved every ``save_every`` frames, so memory
        stays flat. Anything that stops it before the count (an error, or a signal landing
        between two statements) erases the frame's samples: the count and the layer agree, and
        a partial file holds whole frames only."""
        before, time = self.frames_written, float(frame)
        end = self._layer.endTimeCode
        try:
            with Sdf.ChangeBlock():
                write(time)
                self._layer.endTimeCode = time
            self.frames_written = before + 1  # one store: a signal lands before or after it
        except BaseException:
            if self.frames_written == before:
                self._erase_samples(time)
                self._layer.endTimeCode = end
            raise
        if self._save_every > 0 and self.frames_written % self._save_every == 0:
            self._save(f"writing frame {frame}")

    def _erase_samples(self, time: float) -> None:
        """Erase every time sample at ``time`` in the layer."""
        layer, found = self._layer, []
        layer.Traverse(Sdf.Path.absoluteRootPath, lambda path: found.append(path) if path.IsPropertyPath() else None)
        for path in found:
            if layer.QueryTimeSample(path, time) is not None:
                layer.EraseTimeSample(path, time)

    def _save(self, doing: str) -> None:
        """Save the layer; after a failed save the file is never saved again.

        A crate save rewrites the file's table of contents, so a save that fails part way
        leaves a file no reader can open (and saving the layer again crashed USD): the
        writer gives the file up.
        """
        try:
            with _serial_work():
                saved = self._layer.Save()
        except Tf.ErrorException as exc:
            raise self._fail(_FailedSave(_first_line(exc)), doing) from None
        if not saved:
            raise self._fail(_FailedSave("USD reported a failed save"), doing)

    def _release(self, keep: bool) -> bool:
        # Drop every handle before the rename: the layer registry must forget the temporary name.
        if self._layer is None or self._failed:
            self._layer = None
            return False
        try:
            if keep:
                self._save("saving the layer")
        except ClothtoolError:
            return False
        finally:
            self._layer = None
            self._drop_handles()
        return keep

    def _drop_handles(self) -> None:
        """Forget whatever else of the layer a writer holds (before the rename)."""


class UsdCacheWriter(UsdLayerWriter):
    """Stream frames into a USD cache; see the module docstring and formats/cache-usd/v1.md."""

    def __init__(self, path: Path, options: CacheOptions = CacheOptions()):
        super().__init__(path, options)
        self._cloth_paths: list[dict] = []
        self._collider_paths: list[dict] = []

    def write_header(self, header: CacheHeader) -> None:
        self._check_new_header(header)
        try:
            layer = Sdf.Layer.CreateNew(str(self._tmp), _layer_args(self.path))
        except Tf.ErrorException as exc:
            raise write_error(self.path, exc, "creating the USD layer") from None
        if layer is None:
            raise ClothtoolError(f"{self.path}: cannot create the USD layer; check the directory is writable")
        self._header, self._layer = header, layer
        # A composed stage only while authoring the schema prims: UsdGeom fills in the types.
        stage = Usd.Stage.Open(layer)
        _write_stage_metadata(stage, header)
        UsdGeom.Scope.Define(stage, CLOTH_ROOT)
        self._cloth_paths = [_define_cloth(stage, cloth, header) for cloth in header.cloths]
        self._collider_paths = []
        if writes_colliders(header):
            UsdGeom.Scope.Define(stage, COLLIDER_ROOT)
            size = _plane_display_size(header)
            self._collider_paths = [_define_collider(stage, collider, size) for collider in header.colliders]
        del stage

    def write_frame(self, frame: FrameData) -> None:
        header = self._check_next_frame(frame)
        first = self.frames_written == 0
        moved = {}
        if self._collider_paths:  # checked before anything of the frame is written
            moved = deformed_collider_points(header, frame, None if first else self._deforming, self.path)

        def write(time: float) -> None:
            self._write_cloths(frame, time, first)
            self._write_colliders(frame, time, first, moved)

        self._write_whole_frame(frame.frame, write)
        self._deforming = set(moved)

    def _write_cloths(self, frame: FrameData, time: float, first: bool) -> None:
        from clothtool.io.extent_kernel import frame_extent  # numba: writers only, never the reader

        layer = self._layer
        for i, paths in enumerate(self._cloth_paths):
            points = as_points(frame.points[i])
            # vec3f_array: a memcpy into a new array (FromNumpy converts float by float, 10x slower)
            _sample(layer, paths["points"], time, vec3f_array(points), first)
            _sample(layer, paths["extent"], time, vec3f_array(frame_extent(points)), first)
            if "velocities" in paths:
                _sample(layer, paths["velocities"], time, vec3f_array(as_points(frame.velocities[i])), first)
            for field, path in paths["stats"].items():
                layer.SetTimeSample(path, time, float(frame.stats[i][field]))

    def _write_colliders(self, frame: FrameData, time: float, first: bool, moved: dict[int, np.ndarray]) -> None:
        from clothtool.io.extent_kernel import frame_extent

        layer = self._layer
        for i, paths in enumerate(self._collider_paths):
            matrix = Gf.Matrix4d(np.asarray(frame.collider_xforms[i], np.float64).tolist())
            _sample(layer, paths["xform"], time, matrix, first)
            if i in moved:  # deforming mesh colliders only; a static one keeps its rest points
                layer.SetTimeSample(paths["points"], time, vec3f_array(moved[i]))
                layer.SetTimeSample(paths["extent"], time, vec3f_array(frame_extent(moved[i])))


@contextlib.contextmanager
def _serial_work():
    """pxr's work limited to the calling thread for the block. A crate save hands some of its
    packing to worker threads, which then spin waiting for more: ~0.05 ms of CPU time a
    frame at 128^2 for nothing, the save itself taking as long on one thread."""
    limit = Work.GetConcurrencyLimit()
    Work.SetConcurrencyLimit(1)
    try:
        yield
    finally:
        Work.SetConcurrencyLimit(limit)


class _FailedSave(Exception):
    """A failed ``Sdf.Layer.Save``, carrying USD's reason (e.g. "No space left on device")."""


def _first_line(exc: Exception) -> str:
    """The message of a Tf error on one line, without pxr's "Error in '<function>' at line" preamble."""
    text = " ".join(str(exc).split())
    quoted = re.search(r" : '(.*)'", text)
    text = quoted.group(1) if quoted else text
    return text[:200] or type(exc).__name__


def _sample(layer, path: Sdf.Path, time: float, value, with_default: bool) -> None:
    layer.SetTimeSample(path, time, value)
    if with_default:
        # The first frame is also the default value: tools that ignore time samples see the cloth.
        layer.GetAttributeAtPath(path).default = value


def _write_stage_metadata(stage: Usd.Stage, header: CacheHeader) -> None:
    root = UsdGeom.Xform.Define(stage, ROOT)
    Usd.ModelAPI(root).SetKind(Kind.Tokens.component)
    stage.SetDefaultPrim(root.GetPrim())
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y if header.up_axis == "Y" else UsdGeom.Tokens.z)
    UsdGeom.SetStageMetersPerUnit(stage, float(header.meters_per_unit))
    stage.SetTimeCodesPerSecond(float(header.fps))
    stage.SetFramesPerSecond(float(header.fps))
    stage.SetStartTimeCode(float(header.start_frame))
    stage.SetEndTimeCode(float(header.start_frame))  # moves forward as frames are written
    layer = stage.GetRootLayer()
    layer.customLayerData = {
        "clothtool": {
            "format": FORMAT_NAME,
            "formatVersion": FORMAT_VERSION,
            "generator": f"clothtool {__version__}",
            "requestedEndFrame": int(header.end_frame),
            "attributes": Vt.StringArray(sorted(header.attributes | {"faces"})),
            "statsFields": Vt.StringArray(list(header.stats_fields) if "stats" in header.attributes else []),
            "metadata": dict(sorted(header.metadata.items())),
        }
    }


def _define_cloth(stage: Usd.Stage, cloth: ClothTopology, header: CacheHeader) -> dict:
    """Author the cloth's mesh and topology; return the Sdf paths written per frame."""
    mesh = UsdGeom.Mesh.Define(stage, CLOTH_ROOT.AppendChild(cloth.name))
    mesh.CreateFaceVertexCountsAttr(Vt.IntArray.FromNumpy(np.asarray(cloth.face_vertex_counts, np.int32)))
    mesh.CreateFaceVertexIndicesAttr(Vt.IntArray.FromNumpy(np.asarray(cloth.face_vertex_indices, np.int32)))
    mesh.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
    mesh.CreateOrientationAttr(UsdGeom.Tokens.rightHanded)
    primvars = UsdGeom.PrimvarsAPI(mesh)
    if cloth.face_vertex_uv is not None:
        st = primvars.CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.faceVarying)
        st.Set(Vt.Vec2fArray.FromNumpy(np.ascontiguousarray(cloth.face_vertex_uv, np.float32)))
    if "rest" in header.attributes:
        rest = primvars.CreatePrimvar("clothtool:rest", Sdf.ValueTypeNames.Point3fArray, UsdGeom.Tokens.vertex)
        rest.Set(Vt.Vec3fArray.FromNumpy(as_points(cloth.rest_pos)))
    for key in sorted(cloth.vertex_primvars):
        extra = primvars.CreatePrimvar(f"clothtool:{key}", Sdf.ValueTypeNames.FloatArray, UsdGeom.Tokens.vertex)
        extra.Set(Vt.FloatArray.FromNumpy(np.ascontiguousarray(cloth.vertex_primvars[key], np.float32)))
        extra.GetAttr().SetCustomDataByKey("clothtool:units", units.primvar_units(key, header.meters_per_unit))
    paths = {"points": mesh.CreatePointsAttr().GetPath(), "extent": mesh.CreateExtentAttr().GetPath(), "stats": {}}
    if "velocities" in header.attributes:
        paths["velocities"] = mesh.CreateVelocitiesAttr().GetPath()
    if "stats" in header.attributes:
        for field in header.stats_fields:
            attr = mesh.GetPrim().CreateAttribute(_STATS_PREFIX + field, Sdf.ValueTypeNames.Double, custom=True)
            unit, frame = units.stat_units(field)
            attr.SetCustomDataByKey("clothtool:units", unit)
            if frame is not None:
                attr.SetCustomDataByKey("clothtool:frame", frame)
            paths["stats"][field] = attr.GetPath()
    return paths


def _plane_display_size(header: CacheHeader) -> float:
    # A USD plane is finite: draw it four times the size of the cloth, and at least a metre.
    spans = [np.ptp(np.asarray(c.rest_pos, np.float64), axis=0).max() for c in header.cloths]
    return float(max([4.0 * s for s in spans] + [1.0 / header.meters_per_unit]))


def _define_collider(stage: Usd.Stage, collider: ColliderInfo, plane_size: float) -> dict:
    """Author the collider's prim with an animated ``xformOp:transform``; return its paths."""
    path = COLLIDER_ROOT.AppendChild(collider.name)
    params = collider.params
    paths = {}
    if collider.kind == "sphere":
        prim = UsdGeom.Sphere.Define(stage, path)
        prim.CreateRadiusAttr(float(params["radius"]))
    elif collider.kind == "capsule" and np.isclose(params["radius0"], params["radius1"], rtol=1e-6, atol=0):
        prim = UsdGeom.Capsule.Define(stage, path)
        prim.CreateAxisAttr(UsdGeom.Tokens.x)
        prim.CreateHeightAttr(float(params["length"]))
        prim.CreateRadiusAttr(float(params["radius0"]))
    elif collider.kind == "plane":
        prim = UsdGeom.Plane.Define(stage, path)
        prim.CreateAxisAttr(UsdGeom.Tokens.y)  # normal +Y through the local origin
        size = float(params.get("size", plane_size))
        prim.CreateWidthAttr(size)
        prim.CreateLengthAttr(size)
    else:
        prim, paths = _define_collider_mesh(stage, path, collider)
    if isinstance(prim, UsdGeom.Gprim) and not isinstance(prim, UsdGeom.Mesh):
        extent = UsdGeom.Boundable.ComputeExtentFromPlugins(prim, Usd.TimeCode.Default())
        prim.CreateExtentAttr(extent)
    # The exact shape, for readers: the display geometry alone may not give it back.
    # (A key path: customData = {clothtool = {kind, params}}.)
    usd_prim = prim.GetPrim()
    usd_prim.SetCustomDataByKey("clothtool:kind", collider.kind)
    usd_prim.SetCustomDataByKey("clothtool:params", _params_json(params))
    paths["xform"] = UsdGeom.Xformable(prim).AddTransformOp().GetAttr().GetPath()
    return paths


def _define_collider_mesh(stage: Usd.Stage, path: Sdf.Path, collider: ColliderInfo):
    """Tapered capsules, convexes and meshes become meshes (a plain Xform if a convex is open)."""
    params = collider.params
    if collider.kind == "capsule":
        counts, indices, points = tapered_capsule_mesh(float(params["radius0"]), float(params["radius1"]), float(params["length"]))
    elif collider.kind == "convex":
        hull = convex_hull_mesh(params["planes"])
        if hull is None:
            return UsdGeom.Xform.Define(stage, path), {}
        counts, indices, points = hull
    else:
        counts, indices, points = collider.face_vertex_counts, collider.face_vertex_indices, collider.rest_points
    mesh = UsdGeom.Mesh.Define(stage, path)
    mesh.CreateFaceVertexCountsAttr(Vt.IntArray.FromNumpy(np.asarray(counts, np.int32)))
    mesh.CreateFaceVertexIndicesAttr(Vt.IntArray.FromNumpy(np.asarray(indices, np.int32)))
    mesh.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
    points = as_points(points)
    points_attr = mesh.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(points))
    extent_attr = mesh.CreateExtentAttr(Vt.Vec3fArray.FromNumpy(points_extent(points)))
    paths = {}
    if collider.kind == "mesh":
        paths = {"points": points_attr.GetPath(), "extent": extent_attr.GetPath()}
    return mesh, paths


def _params_json(params: dict) -> str:
    """All parameters as canonical JSON, arrays (convex planes) as nested lists."""
    scalars = json.loads(scalar_params_json(params))
    arrays = {k: np.asarray(v, np.float64).tolist() for k, v in params.items() if np.ndim(v)}
    return json.dumps({**scalars, **arrays}, sort_keys=True)


# ---------------------------------------------------------------------------------------------
# The reader.


def read_usd_cache(path: str | os.PathLike) -> "UsdCacheReader":
    """Open a USD cache; raise FormatError if it is missing, truncated or not a clothtool bake."""
    return UsdCacheReader(Path(path))


def _fail(path, message: str):
    raise FormatError(f"{path}: {message}")


class UsdCacheReader(CacheReader):
    """Reads a cache written by UsdCacheWriter through the Sdf layer (API in ``CacheReader``)."""

    def __init__(self, path: Path):
        self.path = path
        self.format_label = path.suffix.lower().lstrip(".")
        if not path.is_file():
            _fail(path, "cache file not found; check the path or bake it with 'clothtool bake'")
        try:
            # Anonymous: never served a stale copy from the layer registry after a re-bake.
            self._layer = Sdf.Layer.OpenAsAnonymous(str(path))
        except Tf.ErrorException as exc:
            _fail(path, f"cannot be read as USD ({_first_line(exc)}); the file is truncated or damaged, bake it again")
        if self._layer is None:
            _fail(path, "cannot be read as USD; the file is truncated or damaged, bake it again")
        try:
            self._load()
        except FormatError:
            self._layer = None
            raise
        except (Tf.ErrorException, KeyError, ValueError, TypeError) as exc:
            self._layer = None
            _fail(path, f"cannot be read as a cache ({_first_line(exc)}); the file is damaged, bake it again")

    def close(self) -> None:
        self._layer = None

    def _load(self) -> None:
        layer, path = self._layer, self.path
        info = dict(layer.customLayerData).get("clothtool")
        if not isinstance(info, dict) or info.get("format") != FORMAT_NAME or not layer.GetPrimAtPath(CLOTH_ROOT):
            _fail(path, "has no clothtool bake root (/Bake with customLayerData clothtool); give a cache written by 'clothtool bake'")
        version = int(info.get("formatVersion", -1))
        if version != FORMAT_VERSION:
            _fail(path, f"cache format version {version} is not supported (this clothtool reads {FORMAT_VERSION}); bake it again")
        cloth_specs = list(layer.GetPrimAtPath(CLOTH_ROOT).nameChildren)
        collider_root = layer.GetPrimAtPath(COLLIDER_ROOT)
        collider_specs = list(collider_root.nameChildren) if collider_root else []
        times = sorted(layer.ListAllTimeSamples())
        self.frames = [int(round(t)) for t in times]
        start = int(round(layer.startTimeCode))
        self.requested_end_frame = int(info.get("requestedEndFrame", start))
        self.header = CacheHeader(
            fps=float(layer.timeCodesPerSecond),
            start_frame=start,
            end_frame=self.frames[-1] if self.frames else start - 1,
            meters_per_unit=float(layer.pseudoRoot.GetInfo("metersPerUnit")),
            up_axis=str(layer.pseudoRoot.GetInfo("upAxis")),
            cloths=tuple(self._cloth_topology(spec) for spec in cloth_specs),
            colliders=tuple(self._collider_info(spec) for spec in collider_specs),
            attributes=frozenset(info.get("attributes", ())),
            stats_fields=tuple(info.get("statsFields", ())),
            metadata={str(k): str(v) for k, v in sorted(dict(info.get("metadata", {})).items())},
        )
        self._check_loaded()

    def _default(self, spec, name: str, dtype):
        attr = spec.attributes.get(name) if spec is not None else None
        if attr is None or attr.default is None:
            return None
        return np.array(attr.default, dtype)  # a copy: crate arrays may map the file

    def _cloth_topology(self, spec) -> ClothTopology:
        points = self._default(spec, "points", np.float32)
        rest = self._default(spec, _PRIMVAR_PREFIX + "rest", np.float32)
        primvars = {
            name[len(_PRIMVAR_PREFIX):]: self._default(spec, name, np.float32)
            for name in spec.attributes.keys()
            if name.startswith(_PRIMVAR_PREFIX) and name != _PRIMVAR_PREFIX + "rest"
        }
        if rest is None:
            rest = points if points is not None else np.zeros((0, 3), np.float32)  # first frame stands in
        return ClothTopology(
            name=spec.name,
            rest_pos=rest,
            face_vertex_counts=self._default(spec, "faceVertexCounts", np.int32),
            face_vertex_indices=self._default(spec, "faceVertexIndices", np.int32),
            face_vertex_uv=self._default(spec, "primvars:st", np.float32),
            vertex_primvars=dict(sorted(primvars.items())),
        )

    def _collider_info(self, spec) -> ColliderInfo:
        info = dict(spec.customData).get("clothtool", {})
        params = json.loads(info["params"])
        kind = str(info["kind"])
        if "planes" in params:
            params["planes"] = np.asarray(params["planes"], np.float64)
        mesh = kind == "mesh"
        return ColliderInfo(
            name=spec.name,
            kind=kind,
            params=params,
            face_vertex_counts=self._default(spec, "faceVertexCounts", np.int32) if mesh else None,
            face_vertex_indices=self._default(spec, "faceVertexIndices", np.int32) if mesh else None,
            rest_points=self._default(spec, "points", np.float32) if mesh else None,
        )

    def _query(self, path: Sdf.Path, frame: int):
        self._frame_index(frame)
        try:
            return self._layer.QueryTimeSample(path, float(frame))
        except Tf.ErrorException as exc:
            _fail(self.path, f"frame {frame} cannot be read ({_first_line(exc)}); the file is damaged, bake it again")

    def _cloth_attr(self, cloth: str, name: str) -> Sdf.Path:
        self._cloth_index(cloth)
        return CLOTH_ROOT.AppendChild(cloth).AppendProperty(name)

    def points(self, cloth: str, frame: int) -> np.ndarray:
        return np.array(self._query(self._cloth_attr(cloth, "points"), frame), np.float32)

    def velocities(self, cloth: str, frame: int) -> np.ndarray | None:
        path = self._cloth_attr(cloth, "velocities")
        if self._layer.GetAttributeAtPath(path) is None:
            return None
        return np.array(self._query(path, frame), np.float32)

    def extent(self, cloth: str, frame: int) -> np.ndarray:
        return np.array(self._query(self._cloth_attr(cloth, "extent"), frame), np.float32)

    def stats(self, cloth: str) -> dict[str, np.ndarray] | None:
        self._cloth_index(cloth)
        if "stats" not in self.header.attributes or not self.header.stats_fields:
            return None
        return {
            field: np.array([self._query(self._cloth_attr(cloth, _STATS_PREFIX + field), f) for f in self.frames], np.float64)
            for field in self.header.stats_fields
        }

    def collider_xform(self, collider: str, frame: int) -> np.ndarray:
        self._collider_index(collider)
        path = COLLIDER_ROOT.AppendChild(collider).AppendProperty("xformOp:transform")
        return np.array(self._query(path, frame), np.float64)

    def collider_points(self, collider: str, frame: int) -> np.ndarray | None:
        self._collider_index(collider)
        path = COLLIDER_ROOT.AppendChild(collider).AppendProperty("points")
        if self._layer.GetNumTimeSamplesForPath(path) == 0:
            return None
        return np.array(self._query(path, frame), np.float32)

    def _extents(self, cloth: str) -> np.ndarray:
        path = self._cloth_attr(cloth, "extent")
        return np.array([np.array(self._query(path, f), np.float32) for f in self.frames], np.float32).reshape(-1, 2, 3)
