"""Bad shots through the command line: every case of the issue's list (a cloth prim that is no
mesh, a skeleton that cannot be evaluated, blend shapes and skinning clothtool does not do,
time samples that change topology, no cloth prim) ends ``clothtool bake`` with exit code 1,
one line that names the prim and the fix, no traceback and no output file."""

from __future__ import annotations

import pytest
from click.testing import CliRunner
from pxr import Gf, Sdf, Usd, UsdGeom, UsdSkel, Vt

from clothtool.cli import main
from tests.usd.shots import add_cloth, add_skinned_body, collide, define_mesh, new_stage, slab


def _not_a_mesh(stage):
    UsdGeom.Sphere.Define(stage, "/Shot/Ball").GetPrim().CreateAttribute("clothtool:role", Sdf.ValueTypeNames.String).Set("cloth")


def _no_cloth(stage):
    define_mesh(stage, "/Shot/Thing", *slab((0, 0, 0), (1, 1, 1)))


def _broken_skeleton(stage):
    add_cloth(stage)
    add_skinned_body(stage, "/Shot/Char", (1, 5))
    skeleton = UsdSkel.Skeleton(stage.GetPrimAtPath("/Shot/Char/Skel"))
    skeleton.GetBindTransformsAttr().Set(Vt.Matrix4dArray([Gf.Matrix4d(1.0)]))  # 1 matrix for 2 joints


def _blend_shapes(stage):
    add_cloth(stage)
    _, mesh = add_skinned_body(stage, "/Shot/Char", (1, 5))
    shape = UsdSkel.BlendShape.Define(stage, "/Shot/Char/Body/Smile")
    shape.CreateOffsetsAttr(Vt.Vec3fArray([Gf.Vec3f(0, 0.01, 0)]))
    shape.CreatePointIndicesAttr(Vt.IntArray([0]))
    binding = UsdSkel.BindingAPI(mesh.GetPrim())
    binding.CreateBlendShapesAttr(["smile"])
    binding.CreateBlendShapeTargetsRel().SetTargets([shape.GetPath()])
    UsdSkel.Animation(stage.GetPrimAtPath("/Shot/Char/Skel/Anim")).CreateBlendShapesAttr(["smile"])
    UsdSkel.Animation(stage.GetPrimAtPath("/Shot/Char/Skel/Anim")).CreateBlendShapeWeightsAttr(Vt.FloatArray([0.5]))


def _skinned_capsule(stage):
    """UsdSkel can deform a Capsule rigidly; clothtool skins meshes only."""
    add_cloth(stage)
    add_skinned_body(stage, "/Shot/Char", (1, 5))
    capsule = UsdGeom.Capsule.Define(stage, "/Shot/Char/Hat")
    binding = UsdSkel.BindingAPI.Apply(capsule.GetPrim())
    binding.CreateSkeletonRel().SetTargets(["/Shot/Char/Skel"])
    binding.CreateJointIndicesPrimvar(True, 1).Set(Vt.IntArray([0]))
    binding.CreateJointWeightsPrimvar(True, 1).Set(Vt.FloatArray([1.0]))
    collide(capsule.GetPrim())


def _joint_out_of_range(stage):
    add_cloth(stage)
    _, mesh = add_skinned_body(stage, "/Shot/Char", (1, 5))
    UsdSkel.BindingAPI(mesh.GetPrim()).GetJointIndicesPrimvar().Set(Vt.IntArray([0] * 8 + [7] * 8))  # 2 joints


def _body_changes_faces(stage):
    add_cloth(stage)
    points, faces = slab((0, 0, 0), (1, 1, 1))
    mesh = define_mesh(stage, "/Shot/Body", points, faces)
    flat = [int(i) for f in faces for i in f]
    mesh.GetFaceVertexIndicesAttr().Set(Vt.IntArray(flat), Usd.TimeCode(1))
    mesh.GetFaceVertexIndicesAttr().Set(Vt.IntArray(flat[::-1]), Usd.TimeCode(3))
    collide(mesh.GetPrim())


def _body_changes_point_count(stage):
    add_cloth(stage)
    points, faces = slab((0, 0, 0), (1, 1, 1))
    mesh = define_mesh(stage, "/Shot/Body", points, faces)
    mesh.GetPointsAttr().Set(Vt.Vec3fArray.FromNumpy(points.astype("f4")), Usd.TimeCode(1))
    mesh.GetPointsAttr().Set(Vt.Vec3fArray.FromNumpy(points[:7].astype("f4")), Usd.TimeCode(3))
    collide(mesh.GetPrim())


def _cloth_changes_faces(stage):
    """The output layer overrides the garment's points at every frame: its faces must not move."""
    indices = add_cloth(stage).GetFaceVertexIndicesAttr()
    flat = list(indices.Get())
    indices.Set(Vt.IntArray(flat), Usd.TimeCode(1))
    indices.Set(Vt.IntArray(flat[::-1]), Usd.TimeCode(4))


def _cloth_changes_point_count(stage):
    points_attr = add_cloth(stage).GetPointsAttr()
    points = list(points_attr.Get())
    points_attr.Set(Vt.Vec3fArray(points), Usd.TimeCode(1))
    points_attr.Set(Vt.Vec3fArray(points + points[:1]), Usd.TimeCode(2))


# (build, prim path, words of the fix)
CASES = {
    "cloth-not-a-mesh": (_not_a_mesh, "/Shot/Ball", "is a Sphere, not a Mesh; mark the garment's Mesh prim"),
    "no-cloth-prim": (_no_cloth, None, 'no cloth prim found; mark the garment\'s Mesh with clothtool:role = "cloth"'),
    "skeleton-not-evaluable": (_broken_skeleton, "/Shot/Char/Body", "fix the skeleton export"),
    "blend-shapes": (_blend_shapes, "/Shot/Char/Body", "bake the body to a point cache"),
    "skinned-capsule": (_skinned_capsule, "/Shot/Char/Hat", "clothtool skins Mesh prims only"),
    "joint-out-of-range": (_joint_out_of_range, "/Shot/Char/Body", "check the skin binding"),
    "body-changes-faces": (_body_changes_faces, "/Shot/Body", "export a fixed-topology mesh"),
    "body-changes-point-count": (_body_changes_point_count, "/Shot/Body", "export a fixed-topology mesh"),
    "cloth-changes-faces": (_cloth_changes_faces, "/Shot/Cloth", "export its rest shape without time samples"),
    "cloth-changes-point-count": (_cloth_changes_point_count, "/Shot/Cloth", "export its rest shape without time samples"),
}


@pytest.mark.parametrize("case", list(CASES))
def test_a_bad_shot_fails_in_one_line_naming_the_prim_and_the_fix(out_dir, case):
    build, prim, fix = CASES[case]
    shot = out_dir / f"{case}.usda"
    stage = new_stage(shot)
    build(stage)
    stage.GetRootLayer().Save()
    output = out_dir / "cloth.usdc"
    result = CliRunner().invoke(main, ["bake", str(shot), "-o", str(output)])
    assert result.exit_code == 1, result.output
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in result.output, result.output
    assert f"{shot.name}:" in lines[0] and fix in lines[0]
    assert prim is None or f"prim {prim}" in lines[0]
    assert not output.exists() and sorted(p.name for p in out_dir.iterdir()) == [shot.name]
