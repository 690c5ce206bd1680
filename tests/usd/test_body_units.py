"""A TOML scene's USD body in other units than the scene's: a centimetre or Z-up body file is
scaled and turned into the scene's metres and Y up (or the other way round), for still,
point-cached (on an animated, turning xform) and UsdSkel-skinned prims. The expected points
are pxr's own world points put through the unit change written out by hand: a Z-up file's
(x, y, z) is a Y-up scene's (x, z, -y), and its lengths times file/scene metres per unit."""

from __future__ import annotations

import numpy as np
import pytest
from pxr import Gf, Usd, UsdGeom, UsdSkel

from clothtool.cook.cooker import CookOptions, cook_fabric
from clothtool.io.fabric_file import write_fabric
from clothtool.loading import load_scene
from clothtool.mesh.shapes import grid
from tests.usd.shots import add_point_cached_body, add_skinned_body, define_mesh, new_stage, slab

SCENE = """
version = 1
[scene]
fps = 24
frames = [1, 5]
meters_per_unit = {scene_mpu}
up_axis = "{scene_up}"
[solver]
preset = "preview"
[cloth.sheet]
fabric = "sheet.fabric.h5"
[collider.sway]
kind = "mesh"
mesh = "body.usda"
prim = "/Shot/Rig/Body"
thickness = 0.25
[collider.char]
kind = "mesh"
mesh = "body.usda"
prim = "/Shot/Char/Body"
[collider.wall]
kind = "mesh"
mesh = "body.usda"
prim = "/Shot/Wall"
"""

# (body file metersPerUnit, upAxis, scene meters_per_unit, up_axis)
CASES = [
    (0.01, "Y", 1.0, "Y"),  # a centimetre body in a metre scene
    (1.0, "Z", 1.0, "Y"),  # a Z-up body in a Y-up scene
    (0.01, "Z", 1.0, "Y"),  # both
    (1.0, "Y", 0.01, "Z"),  # a metre Y-up body in a centimetre Z-up scene
]


def _expected(points: np.ndarray, file_mpu: float, file_up: str, scene_mpu: float, scene_up: str) -> np.ndarray:
    x, y, z = (np.asarray(points, np.float64) * (file_mpu / scene_mpu)).T
    if (file_up, scene_up) == ("Z", "Y"):
        return np.stack([x, z, -y], axis=1)
    if (file_up, scene_up) == ("Y", "Z"):
        return np.stack([x, -z, y], axis=1)
    return np.stack([x, y, z], axis=1)


def _shot(folder, file_mpu: float, file_up: str):
    stage = new_stage(folder / "body.usda", up_axis=file_up, meters_per_unit=file_mpu)
    add_point_cached_body(stage, "/Shot/Rig/Body", (1, 5))
    rig = UsdGeom.Xform.Define(stage, "/Shot/Rig")
    rig.AddTranslateOp().Set(Gf.Vec3d(50.0, 0.0, 10.0))
    turn = rig.AddRotateYOp()
    for frame in range(1, 6):  # the rig turns, so the unit change must reach the track's rotations
        turn.Set(15.0 * (frame - 1), Usd.TimeCode(frame))
    add_skinned_body(stage, "/Shot/Char", (1, 5))
    points, faces = slab((0.0, 0.5, -1.0), (2.0, 1.0, 0.1))
    define_mesh(stage, "/Shot/Wall", points, faces)
    stage.GetRootLayer().Save()
    write_fabric(cook_fabric(grid(4, 4, 0.1, plane="XZ"), CookOptions()).fabric, folder / "sheet.fabric.h5")


def _world(prim, time_code: float, local: np.ndarray) -> np.ndarray:
    m = np.array(UsdGeom.Xformable(prim).ComputeLocalToWorldTransform(Usd.TimeCode(time_code)), np.float64)
    return local @ m[:3, :3] + m[3, :3]


def _collider_world(collider, seconds: float) -> np.ndarray:
    m = collider.matrix(seconds)
    return collider.local_points(seconds) @ m[:3, :3].T + m[:3, 3]


@pytest.fixture(params=CASES, ids=lambda c: f"{c[0]:g}{c[1]}-into-{c[2]:g}{c[3]}")
def converted(request, tmp_path):
    file_mpu, file_up, scene_mpu, scene_up = request.param
    folder = tmp_path / "shot"
    folder.mkdir()
    _shot(folder, file_mpu, file_up)
    (folder / "scene.toml").write_text(SCENE.format(scene_mpu=scene_mpu, scene_up=scene_up))
    scene = load_scene(folder / "scene.toml")
    colliders = {c.name: c for c in scene.colliders.colliders}
    return folder, colliders, request.param


def test_a_point_cached_body_on_a_turning_xform_is_in_scene_units(converted):
    folder, colliders, units = converted
    sway = colliders["sway"]
    assert sway.track is not None and not sway.track.is_static
    assert sway.thickness == 0.25  # the scene's key, in scene units already
    stage = Usd.Stage.Open(str(folder / "body.usda"))
    body = stage.GetPrimAtPath("/Shot/Rig/Body")
    for frame in (1, 2, 3.5, 5):  # sub-frame: the track slerps the turned keys as pxr interpolates the angle
        local = np.array(UsdGeom.Mesh(body).GetPointsAttr().Get(Usd.TimeCode(frame)), np.float64)
        expected = _expected(_world(body, frame, local), *units)
        np.testing.assert_allclose(_collider_world(sway, frame / 24.0), expected, atol=1e-9 + 1e-6 * np.abs(expected).max())


def test_a_skinned_body_is_in_scene_units(converted):
    folder, colliders, units = converted
    char = colliders["char"]
    baked = Usd.Stage.Open(str(folder / "body.usda"))  # pxr's own skinning, then the unit change
    assert UsdSkel.BakeSkinning(UsdSkel.Root(baked.GetPrimAtPath("/Shot/Char")))
    body = baked.GetPrimAtPath("/Shot/Char/Body")
    for frame in range(1, 6):
        local = np.array(UsdGeom.Mesh(body).GetPointsAttr().Get(Usd.TimeCode(frame)), np.float64)
        expected = _expected(_world(body, frame, local), *units)
        np.testing.assert_allclose(_collider_world(char, frame / 24.0), expected, atol=1e-5 * np.abs(expected).max())
    stage = Usd.Stage.Open(str(folder / "body.usda"))
    rest = UsdGeom.Mesh(stage.GetPrimAtPath("/Shot/Char/Body")).GetPointsAttr().Get()
    np.testing.assert_allclose(char.rest_pose(), _expected(np.array(rest, np.float64), *units), rtol=1e-6, atol=1e-9)


def test_a_still_body_is_in_scene_units(converted):
    _, colliders, units = converted
    wall = colliders["wall"]
    assert wall.track is None and wall.deform_points is None
    corners = slab((0.0, 0.5, -1.0), (2.0, 1.0, 0.1))[0]
    np.testing.assert_allclose(wall.mesh_points, _expected(corners, *units), rtol=1e-6, atol=1e-9)


def test_a_centimetre_body_is_the_same_solid_as_the_metre_body(tmp_path):
    """Closed form: the cm wall's corners in a metre scene are the metre numbers (one slab of
    2 x 1 x 0.1 m written as 200 x 100 x 10 cm)."""
    folder = tmp_path / "cm"
    folder.mkdir()
    stage = new_stage(folder / "body.usda", meters_per_unit=0.01)
    corners, faces = slab((0.0, 50.0, -100.0), (200.0, 100.0, 10.0))
    define_mesh(stage, "/Shot/Wall", corners, faces)
    stage.GetRootLayer().Save()
    write_fabric(cook_fabric(grid(4, 4, 0.1, plane="XZ"), CookOptions()).fabric, folder / "sheet.fabric.h5")
    (folder / "scene.toml").write_text(
        SCENE.format(scene_mpu=1.0, scene_up="Y").split("[collider.sway]")[0]
        + '[collider.wall]\nkind = "mesh"\nmesh = "body.usda"\nprim = "/Shot/Wall"\n'
    )
    wall = load_scene(folder / "scene.toml").colliders.colliders[0]
    np.testing.assert_allclose(wall.mesh_points, slab((0.0, 0.5, -1.0), (2.0, 1.0, 0.1))[0], atol=1e-7)
