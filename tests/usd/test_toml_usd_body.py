"""A TOML scene names a USD body: ``kind = "mesh"``, ``mesh = "body.usda"``, ``prim = "/Body"``.
A moving or skinned prim deforms as it would in a USD stage scene (checked against pxr's own
answers: the points it samples, UsdSkel.BakeSkinning); a still prim reads as any mesh."""

from __future__ import annotations

import numpy as np
import pytest
from pxr import Gf, Usd, UsdGeom, UsdSkel

from clothtool.cook.cooker import CookOptions, cook_fabric
from clothtool.errors import ClothtoolError, SceneError
from clothtool.io.fabric_file import write_fabric
from clothtool.loading import load_scene
from clothtool.mesh.shapes import grid
from tests.usd.shots import add_point_cached_body, add_skinned_body, define_mesh, new_stage, slab

SCENE = """
version = 1
[scene]
fps = {fps}
frames = [{start}, {end}]
preroll = {preroll}
[solver]
preset = "preview"
[cloth.sheet]
fabric = "sheet.fabric.h5"
material = "cotton"
[collider.sway]
kind = "mesh"
mesh = "body.usda"
prim = "/Shot/Rig/Body"
thickness = 0.01
friction = 0.3
[collider.char]
kind = "mesh"
mesh = "body.usda"
prim = "/Shot/Char/Body"
[collider.wall]
kind = "mesh"
mesh = "body.usda"
prim = "/Shot/Wall"
"""


@pytest.fixture
def shot(tmp_path):
    """body.usda (24 time codes per second, 1..5): a point-cached box under a moved xform, a
    skinned two-box leg and a still wall; a sheet fabric beside it."""
    stage = new_stage(tmp_path / "body.usda")
    add_point_cached_body(stage, "/Shot/Rig/Body", (1, 5))
    UsdGeom.Xform.Define(stage, "/Shot/Rig").AddTranslateOp().Set(Gf.Vec3d(0.5, 0.0, 0.1))
    add_skinned_body(stage, "/Shot/Char", (1, 5))
    points, faces = slab((0.0, 0.5, -1.0), (2.0, 1.0, 0.1))
    define_mesh(stage, "/Shot/Wall", points, faces)
    stage.GetRootLayer().Save()
    fabric = cook_fabric(grid(4, 4, 0.1, plane="XZ"), CookOptions()).fabric
    write_fabric(fabric, tmp_path / "sheet.fabric.h5")
    return tmp_path


def _scene(folder, fps=24.0, start=1, end=5, preroll=0, extra=""):
    (folder / "scene.toml").write_text(SCENE.format(fps=fps, start=start, end=end, preroll=preroll) + extra)
    return load_scene(folder / "scene.toml")


def _world(prim, time_code: float, local: np.ndarray) -> np.ndarray:
    m = np.array(UsdGeom.Xformable(prim).ComputeLocalToWorldTransform(Usd.TimeCode(time_code)), np.float64)
    return local @ m[:3, :3] + m[3, :3]


def _collider(scene, name):
    return next(c for c in scene.colliders.colliders if c.name == name)


def _world_points(collider, seconds: float) -> np.ndarray:
    m = collider.matrix(seconds)  # column-vector convention
    return collider.local_points(seconds) @ m[:3, :3].T + m[:3, 3]


def test_a_point_cached_prim_deforms_through_the_scene_frames(shot):
    # the scene runs at 48 fps over frames 2..10: the same seconds as time codes 1..5
    scene = _scene(shot, fps=48.0, start=2, end=10)
    sway = _collider(scene, "sway")
    assert sway.kind == "mesh" and sway.deform_points is not None
    assert (sway.thickness, sway.friction) == (0.01, 0.3)  # the table's keys apply
    stage = Usd.Stage.Open(str(shot / "body.usda"))
    body = stage.GetPrimAtPath("/Shot/Rig/Body")
    for frame in (2, 3, 5, 7.5, 10):
        time_code = frame / 2  # pxr interpolates points linearly between samples, as the collider does
        local = np.array(UsdGeom.Mesh(body).GetPointsAttr().Get(Usd.TimeCode(time_code)), np.float64)
        np.testing.assert_allclose(_world_points(sway, frame / scene.fps), _world(body, time_code, local), atol=1e-6)


def test_a_skinned_prim_matches_usdskel_bake_skinning(shot):
    folder = shot
    scene = _scene(folder)
    char = _collider(scene, "char")
    assert char.rest_points is not None and char.track is None
    baked = Usd.Stage.Open(str(folder / "body.usda"))  # pxr's own answer: BakeSkinning writes the points
    assert UsdSkel.BakeSkinning(UsdSkel.Root(baked.GetPrimAtPath("/Shot/Char")))
    body = baked.GetPrimAtPath("/Shot/Char/Body")
    for frame in range(1, 6):
        local = np.array(UsdGeom.Mesh(body).GetPointsAttr().Get(Usd.TimeCode(frame)), np.float64)
        np.testing.assert_allclose(char.local_points(frame / scene.fps), _world(body, frame, local), atol=1e-5)


def test_a_still_prim_is_a_static_mesh(shot):
    scene = _scene(shot)
    wall = _collider(scene, "wall")
    assert wall.deform_points is None and wall.track is None and not wall.is_animated()
    np.testing.assert_allclose(wall.mesh_points, slab((0.0, 0.5, -1.0), (2.0, 1.0, 0.1))[0], atol=1e-6)
    assert _collider(scene, "char").is_animated() and _collider(scene, "sway").is_animated()


def test_preroll_blends_a_moving_body_from_its_rest_pose(shot):
    scene = _scene(shot, start=3, end=5, preroll=2)
    char = _collider(scene, "char")
    assert char.blend == (1.0, 3.0)  # from frame 1 (3 - 2 pre-roll frames) to the first sampled frame
    np.testing.assert_allclose(char.local_points(1 / 24), char.rest_points)


@pytest.mark.parametrize(
    "extra, message",
    [
        ('[collider.bad]\nkind = "mesh"\nmesh = "body.usda"\nprim = "/Shot/Nowhere"\n', "/Shot/Nowhere"),
        ('[collider.bad]\nkind = "mesh"\nmesh = "body.usda"\nprim = "Shot/Wall"\n', "give the mesh prim's path"),
        ('[collider.bad]\nkind = "mesh"\nmesh = "sheet.obj"\nprim = "/Body"\n', "only USD files have prims"),
        ('[collider.bad]\nkind = "mesh"\nmesh = "body.usda"\nprim = "/Shot/Rig/Body"\ndeform = "d.npz"\n', "moves by its own animation; drop 'deform'"),
    ],
)
def test_bad_prims_fail_in_one_line(shot, extra, message):
    folder = shot
    (folder / "sheet.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    with pytest.raises(ClothtoolError, match=message) as caught:
        _scene(folder, extra=extra)
    assert "\n" not in str(caught.value) and "collider.bad" in str(caught.value)
    assert isinstance(caught.value, SceneError)
