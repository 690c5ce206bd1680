"""Small USD shots built with pxr for the stage-loading tests: a garment (a pinned strip of
quads) and bodies of every kind (analytic prims on animated xforms, nested xforms and matrix
ops, a point-cached mesh, a UsdSkel-skinned mesh)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from pxr import Gf, Sdf, Usd, UsdGeom, UsdPhysics, UsdSkel, Vt


def new_stage(path: Path, up_axis: str = "Y", meters_per_unit: float = 1.0, frames=(1, 5), fps: float = 24.0):
    path.parent.mkdir(parents=True, exist_ok=True)
    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageUpAxis(stage, up_axis)
    UsdGeom.SetStageMetersPerUnit(stage, meters_per_unit)
    stage.SetTimeCodesPerSecond(fps)
    stage.SetFramesPerSecond(fps)
    stage.SetStartTimeCode(frames[0])
    stage.SetEndTimeCode(frames[1])
    return stage


def grid(columns: int, rows: int, width: float, height: float):
    """Points of a columns x rows vertex grid in the XY plane (top row at y = 0), quad faces."""
    xs = np.linspace(-width / 2, width / 2, columns)
    ys = np.linspace(0.0, -height, rows)
    points = np.array([(x, y, 0.0) for y in ys for x in xs])
    faces = [(j * columns + i, (j + 1) * columns + i, (j + 1) * columns + i + 1, j * columns + i + 1)
             for j in range(rows - 1) for i in range(columns - 1)]
    return points, np.asarray(faces)


def define_mesh(stage, path: str, points, faces, extra=None):
    mesh = UsdGeom.Mesh.Define(stage, path)
    mesh.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(np.asarray(points, np.float32)))
    mesh.CreateFaceVertexCountsAttr(Vt.IntArray([len(f) for f in faces]))
    mesh.CreateFaceVertexIndicesAttr(Vt.IntArray([int(i) for f in faces for i in f]))
    mesh.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
    for name, values in (extra or {}).items():
        primvar = UsdGeom.PrimvarsAPI(mesh).CreatePrimvar(name, Sdf.ValueTypeNames.FloatArray, UsdGeom.Tokens.vertex)
        primvar.Set(Vt.FloatArray([float(v) for v in values]))
    return mesh


def add_cloth(stage, path: str = "/Shot/Cloth", columns: int = 6, rows: int = 5, size: float = 0.5, offset=(0.0, 1.0, 0.2)):
    """A strip of quads hanging from its pinned top row (primvar ``pin``)."""
    points, faces = grid(columns, rows, size, size)
    points = points + np.asarray(offset)
    pin = [1.0 if k < columns else 0.0 for k in range(len(points))]
    mesh = define_mesh(stage, path, points, faces, {"pin": pin})
    prim = mesh.GetPrim()
    prim.CreateAttribute("clothtool:role", Sdf.ValueTypeNames.String).Set("cloth")
    prim.CreateAttribute("clothtool:cook:pin_attr", Sdf.ValueTypeNames.String).Set("pin")
    return mesh


def collide(prim) -> None:
    UsdPhysics.CollisionAPI.Apply(prim)


def slab(center, size):
    """A box mesh (8 points, 6 outward quads)."""
    c, h = np.asarray(center, float), np.asarray(size, float) / 2
    corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]) * h + c
    faces = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    return corners, faces


def add_point_cached_body(stage, path: str, frames, amplitude: float = 0.1):
    """A box mesh whose points sway along X with time-sampled points."""
    points, faces = slab((0.0, 0.8, 0.0), (0.4, 0.6, 0.2))
    mesh = define_mesh(stage, path, points, faces)
    attr = mesh.GetPointsAttr()
    for frame in range(frames[0], frames[1] + 1):
        moved = points + [amplitude * np.sin(0.5 * (frame - frames[0])), 0.0, 0.0]
        moved[:, 1] += 0.05 * (moved[:, 1] - 0.8) * (frame - frames[0])  # stretch: a real deformation
        attr.Set(Vt.Vec3fArray.FromNumpy(moved.astype(np.float32)), Usd.TimeCode(frame))
    collide(mesh.GetPrim())
    return mesh


def add_skinned_body(stage, root: str, frames, bend_degrees: float = 40.0):
    """A two-joint column of boxes (hip, knee) skinned with UsdSkel; the knee bends over the range."""
    skel_root = UsdSkel.Root.Define(stage, root)
    skeleton = UsdSkel.Skeleton.Define(stage, f"{root}/Skel")
    joints = ["hip", "hip/knee"]
    skeleton.CreateJointsAttr(joints)
    bind = [Gf.Matrix4d(1.0).SetTranslate(Gf.Vec3d(0, 1.0, 0)), Gf.Matrix4d(1.0).SetTranslate(Gf.Vec3d(0, 0.5, 0))]
    skeleton.CreateBindTransformsAttr(Vt.Matrix4dArray(bind))
    rest = [Gf.Matrix4d(1.0).SetTranslate(Gf.Vec3d(0, 1.0, 0)), Gf.Matrix4d(1.0).SetTranslate(Gf.Vec3d(0, -0.5, 0))]
    skeleton.CreateRestTransformsAttr(Vt.Matrix4dArray(rest))
    anim = UsdSkel.Animation.Define(stage, f"{root}/Skel/Anim")
    anim.CreateJointsAttr(joints)
    anim.CreateTranslationsAttr(Vt.Vec3fArray([Gf.Vec3f(0, 1.0, 0), Gf.Vec3f(0, -0.5, 0)]))
    anim.CreateScalesAttr(Vt.Vec3hArray([Gf.Vec3h(1, 1, 1), Gf.Vec3h(1, 1, 1)]))
    rotations = anim.CreateRotationsAttr()
    span = max(frames[1] - frames[0], 1)
    for frame in range(frames[0], frames[1] + 1):
        angle = np.radians(bend_degrees) * (frame - frames[0]) / span
        knee = Gf.Quatf(float(np.cos(angle / 2)), float(np.sin(angle / 2)), 0.0, 0.0)
        hip = Gf.Quatf(float(np.cos(angle / 4)), 0.0, float(np.sin(angle / 4)), 0.0)
        rotations.Set(Vt.QuatfArray([hip, knee]), Usd.TimeCode(frame))
    UsdSkel.BindingAPI.Apply(skeleton.GetPrim()).CreateAnimationSourceRel().SetTargets([anim.GetPath()])
    upper, faces = slab((0, 0.75, 0), (0.2, 0.5, 0.2))
    lower, _ = slab((0, 0.25, 0), (0.2, 0.5, 0.2))
    points = np.vstack([upper, lower])
    faces = list(faces) + [tuple(i + 8 for i in f) for f in faces]
    mesh = define_mesh(stage, f"{root}/Body", points, faces)
    binding = UsdSkel.BindingAPI.Apply(mesh.GetPrim())
    binding.CreateSkeletonRel().SetTargets([skeleton.GetPath()])
    indices = binding.CreateJointIndicesPrimvar(False, 1)
    indices.Set(Vt.IntArray([0] * 8 + [1] * 8))
    weights = binding.CreateJointWeightsPrimvar(False, 1)
    weights.Set(Vt.FloatArray([1.0] * 16))
    binding.CreateGeomBindTransformAttr(Gf.Matrix4d(1.0))
    collide(mesh.GetPrim())
    return skel_root, mesh
