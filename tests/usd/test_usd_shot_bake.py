"""Baking USD shots: attached particles ride the body, the output layer composes over the shot."""

from __future__ import annotations

import numpy as np
import pytest
from pxr import Sdf, Usd, UsdGeom, UsdSkel, UsdValidation

from clothtool.bake import bake
from clothtool.io.cache import CacheOptions
from clothtool.io.memory import MemoryCacheWriter
from clothtool.io.usdshot import ShotLayerWriter
from clothtool.loading import load_usd_scene
from clothtool.solver.attach import bind_attachment, closest_points_on_triangles
from clothtool.solver.kernels.attach import attach_particles
from tests.reference.attach import attach_particles as attach_particles_reference
from tests.usd.shots import add_cloth, add_point_cached_body, add_skinned_body, new_stage

FRAMES = (1, 4)


def _surface_distance(points: np.ndarray, body: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    tri = body[triangles]
    closest = closest_points_on_triangles(points, tri[:, 0], tri[:, 1], tri[:, 2])
    return np.sqrt(np.min(np.sum((closest - points[:, None, :]) ** 2, axis=2), axis=1))


def _pxr_body_points(path, prim_path: str, skinned: bool) -> dict[int, np.ndarray]:
    """Frame -> the body's world points by pxr alone (UsdSkel.BakeSkinning for a skinned
    one, on an anonymous copy of the shot's layer)."""
    stage = Usd.Stage.Open(Sdf.Layer.OpenAsAnonymous(str(path)))
    if skinned:
        assert UsdSkel.BakeSkinning(UsdSkel.Root(stage.GetPrimAtPath(prim_path.rsplit("/", 1)[0])))
    mesh = UsdGeom.Mesh(stage.GetPrimAtPath(prim_path))
    frames = {}
    for frame in range(FRAMES[0], FRAMES[1] + 1):
        local = np.array(mesh.GetPointsAttr().Get(Usd.TimeCode(frame)), np.float64)
        m = np.array(mesh.ComputeLocalToWorldTransform(Usd.TimeCode(frame)), np.float64)
        frames[frame] = local @ m[:3, :3] + m[3, :3]
    return frames


@pytest.mark.parametrize("kind", ["skinned", "point_cached"])
def test_pinned_particles_stay_on_the_body(out_dir, kind):
    """The pinned row starts on the body's front face; at every frame each pinned particle is
    on the body's surface (as pxr poses it) within 1e-5 of the body's size."""
    path = out_dir / f"{kind}.usda"
    stage = new_stage(path, frames=FRAMES)
    if kind == "skinned":
        _, body = add_skinned_body(stage, "/Shot/Char", FRAMES)
        add_cloth(stage, columns=4, rows=4, size=0.15, offset=(0.0, 0.95, 0.1))
    else:
        body = add_point_cached_body(stage, "/Shot/Body", FRAMES)
        add_cloth(stage, columns=4, rows=4, size=0.15, offset=(0.0, 1.0, 0.1))
    stage.GetRootLayer().Save()
    scene = load_usd_scene(path, ["solver.frequency=240"])
    writer = MemoryCacheWriter()
    bake(scene, writer)

    collider = scene.colliders.colliders[0]
    fabric = scene.cloths[0].fabric
    pinned = np.flatnonzero(fabric.in_vertex_order(fabric.particle_inv_mass) == 0)  # the cache is in vertex order
    assert pinned.size == 4
    size = float(np.ptp(collider.rest_pose(), axis=0).max())
    moved = 0.0
    posed = _pxr_body_points(path, str(body.GetPath()), kind == "skinned")
    for frame in range(FRAMES[0], FRAMES[1] + 1):
        body_points = posed[frame]
        cloth = writer.frames[frame][0][pinned]
        distance = _surface_distance(cloth, body_points, collider.mesh_triangles)
        assert distance.max() <= 1e-5 * size, (frame, distance.max())
        moved = max(moved, float(np.abs(cloth - writer.frames[FRAMES[0]][0][pinned]).max()))
    assert moved > 0.01  # the body did carry them


def test_binding_reproduces_rest_and_follows_an_affine_motion():
    """Barycentric weights plus a normal offset: exact at rest, and a rigid motion of the body
    moves the attached points rigidly."""
    rng = np.random.default_rng(3)
    body = rng.normal(size=(30, 3))
    triangles = rng.integers(0, 30, size=(40, 3))
    triangles = triangles[(triangles[:, 0] != triangles[:, 1]) & (triangles[:, 1] != triangles[:, 2]) & (triangles[:, 0] != triangles[:, 2])]
    rest = rng.normal(size=(12, 3))
    binding = bind_attachment(rest, np.arange(12), np.ones(12, bool), body, triangles, "test")
    np.testing.assert_allclose(binding.positions(body), rest, atol=1e-9)
    angle = 0.7
    rotation = np.array([[np.cos(angle), 0, np.sin(angle)], [0, 1, 0], [-np.sin(angle), 0, np.cos(angle)]])
    shift = np.array([0.3, -1.0, 2.0])
    np.testing.assert_allclose(binding.positions(body @ rotation.T + shift), rest @ rotation.T + shift, atol=1e-9)


def test_attach_kernel_matches_reference():
    rng = np.random.default_rng(0)
    particle = np.array([4, 1, 7], np.int32)
    pinned = np.array([True, False, True])
    start, end = (rng.normal(size=(3, 3)).astype(np.float32) for _ in range(2))
    cur = rng.normal(size=(9, 4)).astype(np.float32)
    centers = rng.normal(size=(9, 3)).astype(np.float32)
    expected_cur, expected_centers = cur.copy(), centers.copy()
    attach_particles_reference(particle, pinned, start, end, np.float32(0.25), expected_centers, expected_cur)
    attach_particles(particle, pinned, start, end, np.float32(0.25), centers, cur)
    np.testing.assert_allclose(cur, expected_cur, rtol=1e-6)
    np.testing.assert_allclose(centers, expected_centers, rtol=1e-6)
    assert not np.allclose(cur[1], expected_cur[4])  # unpinned rows keep their position


def test_output_layer_composes_over_the_shot(out_dir):
    path = out_dir / "shot.usda"
    stage = new_stage(path, frames=FRAMES)
    add_skinned_body(stage, "/Shot/Char", FRAMES)
    add_cloth(stage, columns=5, rows=4, size=0.15, offset=(0.0, 0.95, 0.1))
    stage.SetDefaultPrim(stage.GetPrimAtPath("/Shot"))
    UsdGeom.Xform(stage.GetPrimAtPath("/Shot")).AddTranslateOp().Set((0.2, 0.0, 0.0))  # garment points are local
    stage.GetRootLayer().Save()
    scene = load_usd_scene(path, ["solver.frequency=240"])
    memory = MemoryCacheWriter()
    bake(scene, memory)
    output = out_dir / "out" / "cloth.usdc"
    output.parent.mkdir()
    bake(scene, ShotLayerWriter(output, scene, CacheOptions(save_every=2)))

    composed = Usd.Stage.Open(str(output))
    assert composed.GetRootLayer().subLayerPaths[0] == "../shot.usda"  # relative: the pair can move
    assert composed.GetPrimAtPath("/Shot/Char/Body").IsValid()
    cloth = UsdGeom.Mesh(composed.GetPrimAtPath("/Shot/Cloth"))
    assert cloth.GetPointsAttr().GetTimeSamples() == [float(f) for f in range(FRAMES[0], FRAMES[1] + 1)]
    mapping = scene.cloths[0].vertex_particle
    for frame in range(FRAMES[0], FRAMES[1] + 1):
        local = np.array(cloth.GetPointsAttr().Get(Usd.TimeCode(frame)), np.float64)
        m = np.array(cloth.ComputeLocalToWorldTransform(Usd.TimeCode(frame)), np.float64)
        np.testing.assert_allclose(local @ m[:3, :3] + m[3, :3], memory.frames[frame][0][mapping], atol=1e-5)
    registry = UsdValidation.ValidationRegistry()
    errors = UsdValidation.ValidationContext(registry.GetOrLoadAllValidators()).Validate(composed)
    assert [e.GetMessage() for e in errors if e.GetType() == UsdValidation.ValidationErrorType.Error] == []
