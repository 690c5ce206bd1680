"""USD (.usd, .usda, .usdc, .usdz) through pxr."""

from __future__ import annotations

import numpy as np

from clothtool.errors import MeshError
from clothtool.inputs import note_input
from clothtool.io.meshin._common import _gather_uv, _invalid, _reverse_winding
from clothtool.mesh.clothmesh import ClothMesh

_USD_UV_TYPES = ("texCoord2f", "texCoord2d", "texCoord2h")
_USD_SCALAR_TYPES = ("float", "double", "half", "int", "uint", "int64", "uint64", "uchar", "bool")


def read(source: str, prim: str | None) -> ClothMesh:
    from pxr import Sdf, Usd, UsdGeom

    from clothtool.usd_env import quiet_stderr

    with quiet_stderr():  # composition problems are reported below, in one line each
        stage = Usd.Stage.Open(source)
    if stage is None:
        raise _invalid(source, "USD could not open the stage")
    warnings = tuple(
        f"{source}: warning: {' '.join(str(error).split()).rstrip('.')}; fix the asset path in the file"
        for error in stage.GetCompositionErrors()
    )
    for layer in stage.GetUsedLayers():  # sublayers and references are inputs too
        if layer.realPath:
            note_input(layer.realPath)
    up_axis = str(UsdGeom.GetStageUpAxis(stage))
    if up_axis not in ("Y", "Z"):
        raise MeshError(f"{source}: stage upAxis is {up_axis!r}; clothtool reads Y-up or Z-up stages, re-export with one of them")
    meters_per_unit = float(UsdGeom.GetStageMetersPerUnit(stage))
    if not (np.isfinite(meters_per_unit) and meters_per_unit > 0):  # 0 would be read as "unset"
        raise MeshError(
            f"{source}: stage metadata metersPerUnit = {meters_per_unit:g}; it must be a positive size "
            "(0.01 for centimetres, 1 for metres), fix it in the export"
        )
    found = [p for p in stage.Traverse() if p.IsA(UsdGeom.Mesh)]
    if prim is not None:
        absolute = prim.startswith("/") and Sdf.Path.IsValidPathString(prim)
        chosen = stage.GetPrimAtPath(prim) if absolute else None
        if not chosen or not chosen.IsA(UsdGeom.Mesh):
            listing = ", ".join(str(p.GetPath()) for p in found[:8]) + (", ..." if len(found) > 8 else "")
            what = "is not a UsdGeom.Mesh" if chosen else "does not exist"
            raise MeshError(f"{source}: prim '{prim}' {what}; mesh prims in the file: {listing or 'none'}")
    elif found:
        chosen = found[0]
    else:
        raise MeshError(f"{source}: no UsdGeom.Mesh prim in the stage; export the garment as a polygon mesh")
    mesh = UsdGeom.Mesh(chosen)

    points = _usd_first_value(mesh.GetPointsAttr())
    counts = np.asarray(_usd_first_value(mesh.GetFaceVertexCountsAttr()) or [], np.int32)
    indices = np.asarray(_usd_first_value(mesh.GetFaceVertexIndicesAttr()) or [], np.int64)
    if points is None and counts.size:
        raise _invalid(source, f"mesh prim {chosen.GetPath()} has faces but no points")
    if int(counts.sum()) != indices.size or (counts.size and counts.min() < 1):
        raise _invalid(
            source,
            f"mesh prim {chosen.GetPath()}: faceVertexCounts add up to {int(counts.sum())} corners but "
            f"faceVertexIndices has {indices.size}",
        )
    points = np.asarray(points if points is not None else np.zeros((0, 3)), np.float64).reshape(-1, 3)
    # EarliestTime: the value of a static transform, the first sample of an animated one (at
    # Default a transform with samples only reads as identity).
    matrix = np.array(mesh.ComputeLocalToWorldTransform(Usd.TimeCode.EarliestTime()), np.float64)
    with np.errstate(invalid="ignore", over="ignore"):  # NaN points are the cooker's to report
        points = points @ matrix[:3, :3] + matrix[3, :3]  # USD matrices act on row vectors

    n = len(points)
    attrs, uv_primvars = {}, []
    for primvar in UsdGeom.PrimvarsAPI(mesh).GetPrimvarsWithValues():
        name = primvar.GetPrimvarName()
        scalar = str(primvar.GetTypeName().scalarType)
        per_vertex = primvar.GetInterpolation() in (UsdGeom.Tokens.vertex, UsdGeom.Tokens.varying)
        if scalar in _USD_UV_TYPES or (name == "st" and scalar in ("float2", "double2", "half2")):
            uv_primvars.append(primvar)
        elif name == "displayColor" and per_vertex:
            rgb = np.asarray(_usd_first_value(primvar.GetAttr(), primvar.ComputeFlattened), np.float32)
            if rgb.shape == (n, 3):
                attrs.update({"color_r": rgb[:, 0], "color_g": rgb[:, 1], "color_b": rgb[:, 2]})
        elif (
            per_vertex
            and scalar in _USD_SCALAR_TYPES
            and primvar.GetTypeName().isArray
            and primvar.GetElementSize() == 1
        ):
            values = _usd_first_value(primvar.GetAttr(), primvar.ComputeFlattened)
            if values is not None:
                attrs[name.rsplit(":", 1)[-1]] = np.asarray(values, np.float64).reshape(-1)
    face_uv = None
    uv_primvars.sort(key=lambda primvar: primvar.GetPrimvarName() != "st")  # `st`, else the first
    for primvar in uv_primvars[:1]:
        uv = _usd_first_value(primvar.GetAttr(), primvar.ComputeFlattened)
        uv = np.asarray(uv if uv is not None else [], np.float64).reshape(-1, 2)
        interpolation = primvar.GetInterpolation()
        if interpolation == UsdGeom.Tokens.faceVarying and len(uv) == len(indices):
            face_uv = uv
        elif interpolation in (UsdGeom.Tokens.vertex, UsdGeom.Tokens.varying) and len(uv) == n:
            face_uv = _gather_uv(uv, indices)

    clockwise = mesh.GetOrientationAttr().Get() == UsdGeom.Tokens.leftHanded
    mirrored = np.linalg.det(matrix[:3, :3]) < 0
    if clockwise != mirrored and counts.size and counts.min() > 0 and counts.sum() == indices.size:
        order = _reverse_winding(counts, np.arange(indices.size))  # to counter-clockwise
        indices = indices[order]
        face_uv = None if face_uv is None else face_uv[order]
    return ClothMesh(
        vertex_pos=points,
        face_vertex_counts=counts,
        face_vertex_indices=indices,
        face_vertex_uv=face_uv,
        vertex_attrs=attrs,
        source=source,
        meters_per_unit=meters_per_unit,
        up_axis=up_axis,
        warnings=warnings,
    )


def _usd_first_value(attribute, get=None):
    """``get(time)`` (default: ``attribute.Get``) at the default time, else at the attribute's
    earliest time sample; None when neither has a value."""
    from pxr import Usd

    get = get or attribute.Get
    value = get(Usd.TimeCode.Default())
    if value is None:
        samples = attribute.GetTimeSamples()
        if samples:
            value = get(Usd.TimeCode(samples[0]))
    return value


READERS = dict.fromkeys((".usd", ".usda", ".usdc", ".usdz"), read)
