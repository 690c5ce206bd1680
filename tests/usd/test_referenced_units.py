"""A shot in metres and Y up that references a body layer written in centimetres and Z up: the
bodies come out in the shot's units, converted below the referencing prim's own transform
(USD itself composes the reference as it is, a hundred times too large and lying on its back).

The expected points are built without clothtool: pxr's world points of the body layer opened
alone, put through the unit change written out by hand (a Z-up centimetre (x, y, z) is the
Y-up metre (x, z, -y) / 100), then through the referencing prim's transform in the shot."""

from __future__ import annotations

import numpy as np
import pytest
from pxr import Gf, Sdf, Usd, UsdGeom, UsdSkel

from clothtool.loading import load_usd_scene
from tests.usd.shots import add_cloth, add_point_cached_body, add_skinned_body, collide, new_stage

FRAMES = (1, 5)


def _cm_z_up_to_m_y_up(points: np.ndarray) -> np.ndarray:
    x, y, z = np.asarray(points, np.float64).T / 100.0
    return np.stack([x, z, -y], axis=1)


def _world(prim, frame: float, local: np.ndarray) -> np.ndarray:
    m = np.array(UsdGeom.Xformable(prim).ComputeLocalToWorldTransform(Usd.TimeCode(frame)), np.float64)
    return local @ m[:3, :3] + m[3, :3]


def _collider_world(collider, frame: float, local: np.ndarray | None = None) -> np.ndarray:
    m = collider.matrix(frame / 24.0)
    points = collider.local_points(frame / 24.0) if local is None else local
    return points @ m[:3, :3].T + m[:3, 3]


@pytest.fixture
def shot(out_dir):
    body = new_stage(out_dir / "body.usda", up_axis="Z", meters_per_unit=0.01, frames=FRAMES)
    body.SetDefaultPrim(UsdGeom.Xform.Define(body, "/Body").GetPrim())
    add_point_cached_body(body, "/Body/Rig/Box", FRAMES, amplitude=10.0)
    turn = UsdGeom.Xform.Define(body, "/Body/Rig").AddRotateZOp()
    for frame in range(FRAMES[0], FRAMES[1] + 1):
        turn.Set(20.0 * (frame - 1), Usd.TimeCode(frame))
    add_skinned_body(body, "/Body/Char", FRAMES)
    ball = UsdGeom.Sphere.Define(body, "/Body/Ball")
    ball.CreateRadiusAttr(12.0)
    ball.AddTranslateOp().Set(Gf.Vec3d(30.0, 5.0, 90.0))
    collide(ball.GetPrim())
    body.GetRootLayer().Save()

    stage = new_stage(out_dir / "shot.usda", frames=FRAMES)
    add_cloth(stage)
    char = UsdGeom.Xform.Define(stage, "/Shot/Char")
    char.GetPrim().GetReferences().AddReference("body.usda")
    move = char.AddTranslateOp()  # the shot places the character, in the shot's metres
    for frame in range(FRAMES[0], FRAMES[1] + 1):
        move.Set(Gf.Vec3d(0.1 * frame, 0.0, 0.3), Usd.TimeCode(frame))
    stage.GetRootLayer().Save()
    return out_dir


def _placed(shot, frame: float, points_in_body_layer: np.ndarray) -> np.ndarray:
    stage = Usd.Stage.Open(str(shot / "shot.usda"))
    return _world(stage.GetPrimAtPath("/Shot/Char"), frame, _cm_z_up_to_m_y_up(points_in_body_layer))


def test_referenced_bodies_come_in_the_shots_units(shot):
    scene = load_usd_scene(shot / "shot.usda")
    colliders = {c.name: c for c in scene.colliders.colliders}
    assert set(colliders) == {"Box", "Body", "Ball"}
    body = Usd.Stage.Open(Sdf.Layer.OpenAsAnonymous(str(shot / "body.usda")))
    assert UsdSkel.BakeSkinning(UsdSkel.Root(body.GetPrimAtPath("/Body/Char")))
    box, skinned = body.GetPrimAtPath("/Body/Rig/Box"), body.GetPrimAtPath("/Body/Char/Body")
    for frame in (1, 2, 3.5, 5):
        local = np.array(UsdGeom.Mesh(box).GetPointsAttr().Get(Usd.TimeCode(frame)), np.float64)
        np.testing.assert_allclose(_collider_world(colliders["Box"], frame), _placed(shot, frame, _world(box, frame, local)),
                                   atol=1e-6)
        centre = _world(body.GetPrimAtPath("/Body/Ball"), frame, np.zeros((1, 3)))
        np.testing.assert_allclose(_collider_world(colliders["Ball"], frame, colliders["Ball"].centers),
                                   _placed(shot, frame, centre), atol=1e-9)
    ball = colliders["Ball"]
    np.testing.assert_allclose(ball.track.scales * ball.radii[0], 0.12)  # 12 cm
    for frame in range(FRAMES[0], FRAMES[1] + 1):
        local = np.array(UsdGeom.Mesh(skinned).GetPointsAttr().Get(Usd.TimeCode(frame)), np.float64)
        np.testing.assert_allclose(_collider_world(colliders["Body"], frame),
                                   _placed(shot, frame, _world(skinned, frame, local)), atol=1e-6)


def test_a_reference_the_shot_already_converts_is_left_as_it_is(shot):
    """Omniverse's metrics assembler appends unitsResolve ops to the referencing prim; pxr's
    composed stage is then right as it stands."""
    stage = Usd.Stage.Open(str(shot / "shot.usda"))
    char = UsdGeom.Xformable(stage.GetPrimAtPath("/Shot/Char"))
    char.AddRotateXOp(opSuffix="unitsResolve").Set(-90.0)
    char.AddScaleOp(opSuffix="unitsResolve").Set(Gf.Vec3f(0.01, 0.01, 0.01))
    stage.GetRootLayer().Save()
    scene = load_usd_scene(shot / "shot.usda")
    box = next(c for c in scene.colliders.colliders if c.name == "Box")
    prim = stage.GetPrimAtPath("/Shot/Char/Rig/Box")
    local = np.array(UsdGeom.Mesh(prim).GetPointsAttr().Get(Usd.TimeCode(3)), np.float64)
    np.testing.assert_allclose(_collider_world(box, 3), _world(prim, 3, local), atol=1e-6)
    # and the ops do what clothtool's conversion does: the converted body-layer points, moved
    # by the shot's translate at frame 3 (0.3, 0, 0.3)
    body = Usd.Stage.Open(str(shot / "body.usda"))
    source = body.GetPrimAtPath("/Body/Rig/Box")
    original = np.array(UsdGeom.Mesh(source).GetPointsAttr().Get(Usd.TimeCode(3)), np.float64)
    expected = _cm_z_up_to_m_y_up(_world(source, 3, original)) + [0.3, 0.0, 0.3]
    np.testing.assert_allclose(_world(prim, 3, local), expected, atol=1e-6)
