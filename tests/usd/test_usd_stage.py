"""USD stages as scenes: colliders against pxr's own evaluation, units, bad input."""

from __future__ import annotations

import numpy as np
import pytest
from pxr import Gf, Sdf, Usd, UsdGeom, UsdSkel, Vt

from clothtool.errors import SceneError
from clothtool.loading import load_usd_scene
from tests.usd.shots import add_cloth, add_point_cached_body, add_skinned_body, collide, define_mesh, new_stage, slab

SUB_FRAMES = (1.0, 1.25, 1.5, 2.75, 3.0, 4.5)


def _world(prim, frame: float, local: np.ndarray) -> np.ndarray:
    m = np.array(UsdGeom.Xformable(prim).ComputeLocalToWorldTransform(Usd.TimeCode(frame)), np.float64)
    return local @ m[:3, :3] + m[3, :3]


def test_translate_rotate_prim_matches_pxr_at_sub_frames_in_cm_z_up(out_dir):
    """A capsule on animated translate + rotateX ops in a centimetre, Z-up stage: pxr
    interpolates the ops (a single-axis angle linearly, which is what slerp does), so the
    track matches pxr's transform at any sub-frame time."""
    path = out_dir / "cm.usda"
    stage = new_stage(path, up_axis="Z", meters_per_unit=0.01)
    add_cloth(stage, size=50.0, offset=(0.0, 0.0, 150.0))
    capsule = UsdGeom.Capsule.Define(stage, "/Shot/Leg")
    capsule.CreateRadiusAttr(8.0)
    capsule.CreateHeightAttr(80.0)
    capsule.CreateAxisAttr("Z")
    translate, rotate = capsule.AddTranslateOp(), capsule.AddRotateXOp()
    for frame in range(1, 6):
        translate.Set(Gf.Vec3d(3.0 * frame, 0.0, 90.0 - frame), Usd.TimeCode(frame))
        rotate.Set(12.0 * frame, Usd.TimeCode(frame))
    collide(capsule.GetPrim())
    stage.GetRootLayer().Save()

    scene = load_usd_scene(path)
    assert scene.meters_per_unit == 0.01 and scene.up_axis == "Z"
    np.testing.assert_allclose(scene.gravity, [0.0, 0.0, -981.0])
    assert scene.cloths[0].fabric.meters_per_unit == 0.01
    ends = np.array([[0.0, 0.0, -40.0], [0.0, 0.0, 40.0]])
    for frame in SUB_FRAMES:
        arrays = scene.colliders.at(frame / scene.fps)
        np.testing.assert_allclose(arrays.sphere_center, _world(capsule.GetPrim(), frame, ends), atol=1e-4)
        np.testing.assert_allclose(arrays.sphere_radius, [8.0, 8.0], rtol=1e-6)


def test_nested_xforms_match_pxr_at_frames_and_within_the_chord_between(out_dir):
    """A sphere offset from a parent that turns 10 degrees a frame: exact at the frames; in
    between the track moves the centre along the chord of pxr's arc, so the two differ by at
    most the sagitta r (1 - cos(dtheta / 2))."""
    path = out_dir / "nested.usda"
    stage = new_stage(path)
    add_cloth(stage)
    rig = UsdGeom.Xform.Define(stage, "/Shot/Rig")
    rig.AddTranslateOp().Set(Gf.Vec3d(0.0, 0.5, 0.0))
    spin = rig.AddRotateYOp()
    for frame in range(1, 6):
        spin.Set(10.0 * frame, Usd.TimeCode(frame))
    ball = UsdGeom.Sphere.Define(stage, "/Shot/Rig/Ball")
    ball.CreateRadiusAttr(0.1)
    ball.AddTranslateOp().Set(Gf.Vec3d(0.3, 0.0, 0.0))
    collide(ball.GetPrim())
    stage.GetRootLayer().Save()

    scene = load_usd_scene(path)
    sagitta = 0.3 * (1.0 - np.cos(np.radians(10.0) / 2))
    for frame in SUB_FRAMES:
        centre = scene.colliders.at(frame / scene.fps).sphere_center[0]
        expected = _world(ball.GetPrim(), frame, np.zeros((1, 3)))[0]
        tolerance = 1e-6 if frame == int(frame) else sagitta * 1.01
        assert np.linalg.norm(centre - expected) <= tolerance
        assert np.isclose(np.linalg.norm(centre - [0.0, 0.5, 0.0]), 0.3, atol=1e-6 if frame == int(frame) else sagitta)


def test_matrix_op_is_decomposed_and_slerped_where_pxr_shrinks_it(out_dir):
    """xformOp:transform keys 0 and 90 degrees apart: pxr's component-wise blend halfway is a
    rotation scaled by cos 45 degrees; the track keeps the cube rigid, turned 45 degrees."""
    path = out_dir / "matrix.usda"
    stage = new_stage(path, frames=(1, 2))
    add_cloth(stage)
    cube = UsdGeom.Cube.Define(stage, "/Shot/Box")
    cube.CreateSizeAttr(0.4)
    op = cube.AddTransformOp()
    op.Set(Gf.Matrix4d(1.0).SetTranslateOnly(Gf.Vec3d(0, 0.2, 0)), Usd.TimeCode(1))
    turned = Gf.Matrix4d(1.0).SetRotate(Gf.Rotation(Gf.Vec3d(0, 1, 0), 90.0)).SetTranslateOnly(Gf.Vec3d(0, 0.2, 0))
    op.Set(turned, Usd.TimeCode(2))
    collide(cube.GetPrim())
    stage.GetRootLayer().Save()

    scene = load_usd_scene(path)
    pxr_half = np.array(cube.ComputeLocalToWorldTransform(Usd.TimeCode(1.5)), np.float64)[:3, :3]
    assert np.allclose(np.linalg.norm(pxr_half, axis=0)[[0, 2]], np.cos(np.radians(45.0)), atol=1e-6)  # pxr shrinks it
    planes = scene.colliders.at(1.5 / scene.fps).plane
    c, s = np.cos(np.radians(45.0)), np.sin(np.radians(45.0))
    x_face = [c, 0.0, -s]  # local +X turned 45 degrees about +Y
    row = planes[np.argmax(planes[:, :3] @ x_face)]
    np.testing.assert_allclose(row[:3], x_face, atol=1e-6)
    np.testing.assert_allclose(row[3], 0.2, atol=1e-6)  # half the size: not shrunk
    for frame in (1.0, 2.0):
        m = np.array(cube.ComputeLocalToWorldTransform(Usd.TimeCode(frame)), np.float64)
        normals = scene.colliders.at(frame / scene.fps).plane[:, :3]
        np.testing.assert_allclose(np.abs(normals @ m[:3, :3].T).max(axis=1), 1.0, atol=1e-6)


def test_point_cache_matches_pxr_at_sub_frames(out_dir):
    """pxr interpolates time-sampled points linearly, as the collider does."""
    path = out_dir / "cache.usda"
    stage = new_stage(path)
    add_cloth(stage)
    body = add_point_cached_body(stage, "/Shot/Rig/Body", (1, 5))
    UsdGeom.Xform.Define(stage, "/Shot/Rig").AddTranslateOp().Set(Gf.Vec3d(0.5, 0.0, 0.1))
    stage.GetRootLayer().Save()

    scene = load_usd_scene(path)
    for frame in SUB_FRAMES:
        local = np.array(body.GetPointsAttr().Get(Usd.TimeCode(frame)), np.float64)
        expected = _world(body.GetPrim(), frame, local)
        np.testing.assert_allclose(scene.colliders.at(frame / scene.fps).mesh_points, expected, atol=1e-6)


def test_skinned_body_matches_usdskel_bake_skinning(out_dir):
    path = out_dir / "skel.usda"
    stage = new_stage(path)
    add_cloth(stage)
    add_skinned_body(stage, "/Shot/Char", (1, 5))
    stage.GetRootLayer().Save()
    scene = load_usd_scene(path)

    baked = Usd.Stage.Open(str(path))  # pxr's own answer: BakeSkinning writes the points
    assert UsdSkel.BakeSkinning(UsdSkel.Root(baked.GetPrimAtPath("/Shot/Char")))
    body = baked.GetPrimAtPath("/Shot/Char/Body")
    for frame in range(1, 6):
        local = np.array(UsdGeom.Mesh(body).GetPointsAttr().Get(Usd.TimeCode(frame)), np.float64)
        np.testing.assert_allclose(scene.colliders.at(frame / scene.fps).mesh_points, _world(body, frame, local), atol=1e-5)
    collider = scene.colliders.colliders[0]
    assert collider.kind == "mesh" and collider.rest_points is not None


def test_metadata_overrides_and_cloth_settings_from_attributes(out_dir):
    path = out_dir / "shot.usda"
    stage = new_stage(path, frames=(3, 9), fps=30.0)
    cloth = add_cloth(stage).GetPrim()
    cloth.CreateAttribute("clothtool:material", Sdf.ValueTypeNames.String).Set("denim")
    cloth.CreateAttribute("clothtool:material:damping", Sdf.ValueTypeNames.Double).Set(0.3)
    stage.GetRootLayer().customLayerData = {"clothtool": {"solver": "preview", "preroll": 4}}
    stage.GetRootLayer().Save()

    scene = load_usd_scene(path)
    assert (scene.fps, scene.start_frame, scene.end_frame, scene.preroll) == (30.0, 3, 9, 4)
    assert scene.cloths[0].material.damping == 0.3
    assert scene.cloths[0].prim == "/Shot/Cloth" and scene.cloths[0].fabric.particle_inv_mass.min() == 0
    changed = load_usd_scene(path, ["scene.fps=24", "scene.up_axis=Z", "scene.preroll=0"], frames=(1, 2))
    assert (changed.fps, changed.up_axis, changed.preroll, changed.start_frame) == (24.0, "Z", 0, 1)
    with pytest.raises(SceneError, match="unknown key 'colour'"):
        load_usd_scene(path, ["scene.colour=1"])


def test_nested_material_attributes_and_a_solver_table_in_the_layer(out_dir):
    """``clothtool:material:shearing:stiffness`` is the material table's [shearing] stiffness,
    and customLayerData's solver may be a table over a preset, as in a TOML scene."""
    path = out_dir / "nested.usda"
    stage = new_stage(path)
    cloth = add_cloth(stage).GetPrim()
    cloth.CreateAttribute("clothtool:material:shearing:stiffness", Sdf.ValueTypeNames.Double).Set(0.85)
    cloth.CreateAttribute("clothtool:material:damping", Sdf.ValueTypeNames.Double).Set(0.0)
    stage.GetRootLayer().customLayerData = {"clothtool": {"solver": {"preset": "preview", "frequency": 480.0}}}
    stage.GetRootLayer().Save()
    scene = load_usd_scene(path)
    material = scene.cloths[0].material
    assert (material.shearing.stiffness, material.damping) == (0.85, 0.0)
    assert material.horizontal.stiffness == 1.0  # the rest of cotton stays
    assert scene.solver.frequency == 480.0
    cloth.CreateAttribute("clothtool:material:shearing", Sdf.ValueTypeNames.Double).Set(1.0)
    stage.GetRootLayer().Save()
    with pytest.raises(SceneError, match="clothtool:material:shearing is both a value and a namespace"):
        load_usd_scene(path)


# ------------------------------------------------------------------------ bad input
def _one_line(exc) -> str:
    text = str(exc.value)
    assert "\n" not in text
    return text


def test_no_cloth_prim(out_dir):
    path = out_dir / "empty.usda"
    stage = new_stage(path)
    define_mesh(stage, "/Shot/Thing", *slab((0, 0, 0), (1, 1, 1)))
    stage.GetRootLayer().Save()
    with pytest.raises(SceneError) as exc:
        load_usd_scene(path)
    assert "no cloth prim found" in _one_line(exc) and "clothtool:role" in str(exc.value)


def test_cloth_prim_that_is_not_a_mesh(out_dir):
    path = out_dir / "notmesh.usda"
    stage = new_stage(path)
    UsdGeom.Sphere.Define(stage, "/Shot/Ball")
    stage.GetRootLayer().Save()
    with pytest.raises(SceneError) as exc:
        load_usd_scene(path, cloth=("/Shot/Ball",))
    assert "/Shot/Ball is a Sphere, not a Mesh" in _one_line(exc)


def test_time_samples_that_change_topology(out_dir):
    path = out_dir / "topology.usda"
    stage = new_stage(path)
    add_cloth(stage)
    points, faces = slab((0, 0, 0), (1, 1, 1))
    mesh = define_mesh(stage, "/Shot/Body", points, faces)
    indices = mesh.GetFaceVertexIndicesAttr()
    flat = [int(i) for f in faces for i in f]
    indices.Set(Vt.IntArray(flat), Usd.TimeCode(1))
    indices.Set(Vt.IntArray(flat[::-1]), Usd.TimeCode(3))
    collide(mesh.GetPrim())
    stage.GetRootLayer().Save()
    with pytest.raises(SceneError) as exc:
        load_usd_scene(path)
    assert "/Shot/Body changes 'faceVertexIndices' at time code 3" in _one_line(exc)


def test_blend_shapes_are_refused(out_dir):
    path = out_dir / "blend.usda"
    stage = new_stage(path)
    add_cloth(stage)
    _, mesh = add_skinned_body(stage, "/Shot/Char", (1, 5))
    shape = UsdSkel.BlendShape.Define(stage, "/Shot/Char/Body/Smile")
    shape.CreateOffsetsAttr(Vt.Vec3fArray([Gf.Vec3f(0, 0.01, 0)]))
    shape.CreatePointIndicesAttr(Vt.IntArray([0]))
    binding = UsdSkel.BindingAPI(mesh.GetPrim())
    binding.CreateBlendShapesAttr(["smile"])
    binding.CreateBlendShapeTargetsRel().SetTargets([shape.GetPath()])
    stage.GetPrimAtPath("/Shot/Char/Skel/Anim").CreateAttribute("blendShapes", Sdf.ValueTypeNames.TokenArray).Set(["smile"])
    UsdSkel.Animation(stage.GetPrimAtPath("/Shot/Char/Skel/Anim")).CreateBlendShapeWeightsAttr(Vt.FloatArray([0.5]))
    stage.GetRootLayer().Save()
    with pytest.raises(SceneError) as exc:
        load_usd_scene(path)
    assert "/Shot/Char/Body has UsdSkel blend shapes" in _one_line(exc) and "point cache" in str(exc.value)


def test_skeleton_that_cannot_be_evaluated(out_dir):
    path = out_dir / "broken.usda"
    stage = new_stage(path)
    add_cloth(stage)
    add_skinned_body(stage, "/Shot/Char", (1, 5))
    skeleton = UsdSkel.Skeleton(stage.GetPrimAtPath("/Shot/Char/Skel"))
    skeleton.GetBindTransformsAttr().Set(Vt.Matrix4dArray([Gf.Matrix4d(1.0)]))  # 1 matrix for 2 joints
    stage.GetRootLayer().Save()
    with pytest.raises(SceneError) as exc:
        load_usd_scene(path)
    text = _one_line(exc)
    assert "/Shot/Char/Body" in text and "/Shot/Char/Skel" in text
