"""USD cache: schema, stage metadata, default values, colliders, pxr's validators, memory."""

from __future__ import annotations

import re
import warnings

import numpy as np
import pytest
from pxr import Gf, Sdf, Usd, UsdGeom, UsdValidation
from test_cache_roundtrip import CUBE, assert_roundtrip, files_in, make_frame, make_header, memory_growth_mb, write_cache

from clothtool.errors import FormatError
from clothtool.io.cache import CacheOptions
from clothtool.io.usdcache import UsdCacheWriter, convex_hull_mesh, read_usd_cache, tapered_capsule_mesh


@pytest.fixture
def baked(out_dir):
    header = make_header()
    path = out_dir / "shot.usdc"
    frames = write_cache(path, header, options=CacheOptions(save_every=3))
    return path, header, frames


def mesh_volume(counts, indices, points) -> float:
    """Signed volume (positive when faces wind counter-clockwise seen from outside)."""
    points = np.asarray(points, np.float64)
    volume, start = 0.0, 0
    for count in counts:
        face = indices[start : start + count]
        for k in range(1, count - 1):
            volume += np.linalg.det(points[[face[0], face[k], face[k + 1]]]) / 6
        start += count
    return volume


@pytest.mark.parametrize("save_every", [1, 0])
def test_roundtrip_whatever_the_save_interval(out_dir, save_every):
    header = make_header()
    path = out_dir / "shot.usdc"
    assert_roundtrip(path, header, write_cache(path, header, options=CacheOptions(save_every=save_every)))


def test_stage_metadata(baked):
    path, header, _ = baked
    stage = Usd.Stage.Open(str(path))
    assert UsdGeom.GetStageUpAxis(stage) == "Y" and UsdGeom.GetStageMetersPerUnit(stage) == 0.01
    assert stage.GetTimeCodesPerSecond() == 30 and stage.GetFramesPerSecond() == 30
    assert (stage.GetStartTimeCode(), stage.GetEndTimeCode()) == (3, 10)
    assert stage.GetDefaultPrim().GetPath() == "/Bake" and Usd.ModelAPI(stage.GetDefaultPrim()).GetKind() == "component"
    info = stage.GetRootLayer().customLayerData["clothtool"]
    assert info["format"] == "clothtool-cache" and info["formatVersion"] == 1
    assert dict(info["metadata"]) == header.metadata and list(info["statsFields"]) == ["residual", "iterations"]


def test_cloth_mesh_schema_and_default_values(baked):
    path, header, frames = baked
    stage = Usd.Stage.Open(str(path))
    mesh = UsdGeom.Mesh(stage.GetPrimAtPath("/Bake/Cloth/skirt"))
    assert mesh and mesh.GetSubdivisionSchemeAttr().Get() == "none" and mesh.GetOrientationAttr().Get() == "rightHanded"
    first = frames[0]
    # Tools that ignore time samples see the first frame.
    np.testing.assert_array_equal(np.array(mesh.GetPointsAttr().Get()), first.points[0])
    np.testing.assert_array_equal(np.array(mesh.GetVelocitiesAttr().Get()), first.velocities[0])
    np.testing.assert_array_equal(np.array(mesh.GetExtentAttr().Get()), [first.points[0].min(0), first.points[0].max(0)])
    assert mesh.GetPointsAttr().GetTimeSamples() == [float(f.frame) for f in frames]
    np.testing.assert_array_equal(np.array(mesh.GetPointsAttr().Get(7)), frames[4].points[0])
    for t in (3, 10):  # extent agrees with what USD computes from the points
        np.testing.assert_allclose(np.array(mesh.GetExtentAttr().Get(t)), np.array(UsdGeom.Mesh.ComputeExtent(mesh.GetPointsAttr().Get(t))))
    primvars = UsdGeom.PrimvarsAPI(mesh)
    assert primvars.GetPrimvar("st").GetInterpolation() == "faceVarying"
    assert primvars.GetPrimvar("st").GetTypeName() == Sdf.ValueTypeNames.TexCoord2fArray
    for name in ("clothtool:pin", "clothtool:max_distance", "clothtool:rest"):
        assert primvars.GetPrimvar(name).GetInterpolation() == "vertex"
    assert not UsdGeom.PrimvarsAPI(stage.GetPrimAtPath("/Bake/Cloth/scarf")).HasPrimvar("st")  # no UVs, no st
    stats = mesh.GetPrim().GetAttribute("clothtool:stats:residual")
    assert stats.Get(4) == frames[1].stats[0]["residual"]
    ok, reason = UsdGeom.Mesh.ValidateTopology(mesh.GetFaceVertexIndicesAttr().Get(), mesh.GetFaceVertexCountsAttr().Get(), 25)
    assert ok, reason


def test_colliders_are_animated_usdgeom_prims(baked):
    path, header, frames = baked
    stage = Usd.Stage.Open(str(path))
    types = {p.GetName(): p.GetTypeName() for p in stage.GetPrimAtPath("/Bake/Colliders").GetChildren()}
    assert types == {"ball": "Sphere", "arm": "Mesh", "leg": "Capsule", "floor": "Plane", "box": "Mesh", "body": "Mesh"}
    assert UsdGeom.Sphere(stage.GetPrimAtPath("/Bake/Colliders/ball")).GetRadiusAttr().Get() == 0.25
    leg = UsdGeom.Capsule(stage.GetPrimAtPath("/Bake/Colliders/leg"))
    assert (leg.GetAxisAttr().Get(), leg.GetHeightAttr().Get(), leg.GetRadiusAttr().Get()) == ("X", 0.5, 0.15)
    assert UsdGeom.Plane(stage.GetPrimAtPath("/Bake/Colliders/floor")).GetAxisAttr().Get() == "Y"
    for k, collider in enumerate(header.colliders):
        xformable = UsdGeom.Xformable(stage.GetPrimAtPath(f"/Bake/Colliders/{collider.name}"))
        for frame in (frames[0], frames[-1]):
            world = xformable.ComputeLocalToWorldTransform(frame.frame)
            np.testing.assert_allclose(np.array(world), frame.collider_xforms[k], atol=1e-12)
        # USD's row-vector convention: the local origin lands on the last row's translation.
        moved = xformable.ComputeLocalToWorldTransform(frames[-1].frame).Transform(Gf.Vec3d(0, 0, 0))
        np.testing.assert_allclose(list(moved), frames[-1].collider_xforms[k][3, :3], atol=1e-12)
    box = UsdGeom.Mesh(stage.GetPrimAtPath("/Bake/Colliders/box"))
    assert mesh_volume(box.GetFaceVertexCountsAttr().Get(), box.GetFaceVertexIndicesAttr().Get(), box.GetPointsAttr().Get()) == pytest.approx(1.0)
    body = UsdGeom.Mesh(stage.GetPrimAtPath("/Bake/Colliders/body"))
    np.testing.assert_array_equal(np.array(body.GetPointsAttr().Get(5)), frames[2].collider_points[5])


def test_tapered_capsule_mesh_is_closed_and_outward():
    counts, indices, points = tapered_capsule_mesh(0.3, 0.1, 1.0)
    # Every edge is shared by exactly two faces, in opposite directions: closed and consistent.
    edges, start = [], 0
    for count in counts:
        face = indices[start : start + count]
        edges += [(face[k], face[(k + 1) % count]) for k in range(count)]
        start += count
    assert sorted(edges) == sorted((b, a) for a, b in edges)
    spheres = 4 / 3 * np.pi * (0.3**3 + 0.1**3)
    assert 0.9 * spheres < mesh_volume(counts, indices, points) < 2 * spheres
    assert points[:, 0].min() == pytest.approx(-0.8) and points[:, 0].max() == pytest.approx(0.6)


def test_convex_hull_follows_the_scene_plane_convention():
    cube = convex_hull_mesh(CUBE * [1, 1, 1, 0.5])  # solid side n.x < d: the cube [-0.5, 0.5]^3
    assert mesh_volume(*cube) == pytest.approx(1.0)
    np.testing.assert_allclose(cube[2].min(axis=0), -0.5) and np.testing.assert_allclose(cube[2].max(axis=0), 0.5)
    open_solid = np.array([[0, 1, 0, 0], [1, 0, 0, 0], [0, 0, 1, 0], [-1, 0, 0, 1.0]])
    empty = CUBE * [1, 1, 1, 1] - [0, 0, 0, 2]  # every d = -1: no point is inside all six
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert convex_hull_mesh(open_solid) is None and convex_hull_mesh(empty) is None


def test_pxr_validators_report_no_errors(baked):
    path, _, _ = baked
    validators = UsdValidation.ValidationRegistry().GetOrLoadAllValidators()
    context = UsdValidation.ValidationContext(validators)
    errors = context.Validate(Usd.Stage.Open(str(path)))
    assert [e.GetErrorAsString() for e in errors] == []
    # The same validators do catch a stage without the metadata we write (so they really ran).
    bare = Usd.Stage.CreateInMemory()
    UsdGeom.Mesh.Define(bare, "/m")
    names = {e.GetName() for e in context.Validate(bare)}
    assert {"MissingDefaultPrim", "MissingUpAxisMetadata", "MissingMetersPerUnitMetadata"} <= names


def test_temporary_file_keeps_the_suffix(out_dir):
    header = make_header()
    with UsdCacheWriter(out_dir / "shot.usdc", CacheOptions()) as writer:
        writer.write_header(header)
        writer.write_frame(make_frame(header, 3))
        (tmp,) = files_in(out_dir)
        assert re.fullmatch(r"\.shot\.usdc\.clothtool-tmp\.\d+\.\d+\.[0-9a-f]{8}\.usdc", tmp)
        writer.commit()
    assert files_in(out_dir) == ["shot.usdc"]


def test_usd_suffix_is_crate(out_dir):
    write_cache(out_dir / "shot.usd", make_header())
    assert (out_dir / "shot.usd").read_bytes()[:8] == b"PXR-USDC"


@pytest.mark.parametrize("suffix", [".usdc", ".usda"])
def test_no_paths_or_timestamps(out_dir, suffix):
    write_cache(out_dir / f"shot{suffix}", make_header())
    data = (out_dir / f"shot{suffix}").read_bytes()
    assert str(out_dir).encode() not in data and b"clothtool-tmp" not in data and b"/tmp" not in data
    assert not re.search(rb"20\d\d-\d\d-\d\d|\d\d:\d\d:\d\d", data)
    layer = Sdf.Layer.OpenAsAnonymous(str(out_dir / f"shot{suffix}"))
    assert layer.documentation == "" and layer.comment == ""


def test_partial_file_ends_at_the_last_frame(out_dir):
    header = make_header()
    with pytest.raises(RuntimeError):
        with UsdCacheWriter(out_dir / "shot.usdc", CacheOptions(save_every=10)) as writer:
            writer.write_header(header)
            for f in (3, 4):
                writer.write_frame(make_frame(header, f))
            raise RuntimeError("unstable")
    stage = Usd.Stage.Open(str(out_dir / "shot.partial.usdc"))
    assert (stage.GetStartTimeCode(), stage.GetEndTimeCode()) == (3, 4)


def test_a_frame_that_fails_half_way_is_not_kept(out_dir, monkeypatch):
    header = make_header()
    with pytest.raises(RuntimeError, match="disk full"):
        with UsdCacheWriter(out_dir / "shot.usdc", CacheOptions()) as writer:
            writer.write_header(header)
            for f in (3, 4):
                writer.write_frame(make_frame(header, f))

            def fail(*args):
                raise RuntimeError("disk full")

            monkeypatch.setattr(writer, "_write_colliders", fail)  # after the cloths of frame 5
            writer.write_frame(make_frame(header, 5))
    with read_usd_cache(out_dir / "shot.partial.usdc") as cache:
        assert cache.frames == [3, 4]
    stage = Usd.Stage.Open(str(out_dir / "shot.partial.usdc"))
    assert stage.GetEndTimeCode() == 4  # the frame cut short left no end time either


def test_reader_sees_a_rebake_at_the_same_path(out_dir):
    path = out_dir / "shot.usdc"
    write_cache(path, make_header(end=5))
    with read_usd_cache(path) as cache:
        assert cache.frames == [3, 4, 5]
    write_cache(path, make_header(end=8))
    with read_usd_cache(path) as cache:
        assert cache.frames == [3, 4, 5, 6, 7, 8]


def test_usd_without_bake_root_is_refused(out_dir):
    path = out_dir / "scene.usda"
    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.Sphere.Define(stage, "/Ball")
    stage.Save()
    del stage
    with pytest.raises(FormatError, match="has no clothtool bake root .*; give a cache written by 'clothtool bake'"):
        read_usd_cache(path)


def test_memory_grows_without_periodic_saves(out_dir):
    """The control for test_memory_stays_flat: without saves, pxr holds every sample in memory."""
    raw_mb = 300 * 20_000 * 12 / 2**20
    assert memory_growth_mb(out_dir / "kept.usdc", 20_000, 300, CacheOptions(save_every=0)) > raw_mb / 2
    assert memory_growth_mb(out_dir / "saved.usdc", 20_000, 300, CacheOptions(save_every=10)) < raw_mb / 4


def test_saves_run_pxr_work_on_the_calling_thread_and_restore_its_limit():
    """The crate save's worker threads only spun (CPU time for nothing): the limit is 1
    for the block and the caller's own afterwards, after an error too."""
    from pxr import Work

    from clothtool.io.usdcache import _serial_work

    before = Work.GetConcurrencyLimit()
    with _serial_work():
        assert Work.GetConcurrencyLimit() == 1
    assert Work.GetConcurrencyLimit() == before
    with pytest.raises(RuntimeError, match="save failed"):
        with _serial_work():
            raise RuntimeError("save failed")
    assert Work.GetConcurrencyLimit() == before
