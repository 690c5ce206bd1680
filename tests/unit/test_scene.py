"""Scene files: tracks (keys, files, interpolation), colliders, overrides and every bad input."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from clothtool.errors import SceneError
from clothtool.scene.overrides import apply_overrides
from clothtool.loading import load_scene
from clothtool.scene.tracks import Track, decompose_matrix, euler_xyz_to_quat, quat_to_matrix, slerp

from tests.conftest import EXAMPLES

HEADER = f"""
[scene]
fps = 10.0
frames = [0, 10]
[cloth.c]
mesh = "{(EXAMPLES / 'cape' / 'cape.obj').as_posix()}"
cook = {{ pin_attr = "color_r" }}
"""


def scene_with(tmp_path: Path, text: str):
    path = tmp_path / "scene.toml"
    path.write_text(HEADER + text)
    return load_scene(path)


def error_of(tmp_path: Path, text: str) -> str:
    with pytest.raises(SceneError) as info:
        scene_with(tmp_path, text)
    message = str(info.value)
    assert "\n" not in message and "scene.toml" in message
    return message


# ------------------------------------------------------------------ tracks
def test_linear_track_interpolates_translation_and_slerps_rotation(tmp_path):
    scene = scene_with(tmp_path, """
[track.t]
keys = [ { time = 0, translate = [0, 0, 0] }, { time = 10, translate = [10, 0, 0], rotate_euler = [0, 90, 0] } ]
""")
    track = scene.tracks["t"]
    sample = track.sample(0.5)  # frame 5 at 10 fps: half way
    np.testing.assert_allclose(sample.translation, [5, 0, 0])
    np.testing.assert_allclose(sample.rotation_matrix(), quat_to_matrix(euler_xyz_to_quat([0, 45, 0])), atol=1e-12)
    np.testing.assert_allclose(track.sample(-1.0).translation, [0, 0, 0])  # held before the first key
    np.testing.assert_allclose(track.sample(5.0).translation, [10, 0, 0])  # and after the last


def test_step_and_cubic_interpolation(tmp_path):
    keys = "keys = [ { time = 0, translate = [0, 0, 0] }, { time = 5, translate = [1, 0, 0] }, { time = 10, translate = [2, 0, 0] } ]"
    scene = scene_with(tmp_path, f"""
[track.s]
interpolation = "step"
{keys}
[track.c]
interpolation = "cubic"
{keys}
""")
    assert scene.tracks["s"].sample(0.49).translation[0] == 0.0
    assert scene.tracks["s"].sample(0.5).translation[0] == 1.0
    # evenly spaced collinear keys: Catmull-Rom reproduces the straight line in the interior
    np.testing.assert_allclose(scene.tracks["c"].sample(0.75).translation, [1.5, 0, 0], atol=1e-12)


def test_seconds_time_unit_and_matrix_keys(tmp_path):
    scene = scene_with(tmp_path, """
[track.m]
time_unit = "seconds"
keys = [ { time = 0.0, matrix = [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]] },
         { time = 2.0, matrix = [[0,0,2,4],[0,2,0,5],[-2,0,0,6],[0,0,0,1]] } ]
""")
    end = scene.tracks["m"].sample(2.0)
    np.testing.assert_allclose(end.translation, [4, 5, 6])
    np.testing.assert_allclose(end.scale, [2, 2, 2])
    np.testing.assert_allclose(end.rotation_matrix(), quat_to_matrix(euler_xyz_to_quat([0, 90, 0])), atol=1e-12)
    # half way the matrix is interpolated as translation, rotation and scale, never component-wise
    mid = scene.tracks["m"].sample(1.0)
    np.testing.assert_allclose(mid.scale, [1.5, 1.5, 1.5])
    assert abs(np.linalg.det(mid.rotation_matrix()) - 1) < 1e-12


def test_csv_and_npz_tracks(tmp_path):
    (tmp_path / "t.csv").write_text("frame,tx,ty,tz,qw,qx,qy,qz,s\n0,0,0,0,1,0,0,0,1\n10,1,2,3,1,0,0,0,2\n")
    np.savez(tmp_path / "t.npz", time=np.array([0.0, 1.0]), translate=np.array([[0, 0, 0], [0, 4, 0]], float))
    scene = scene_with(tmp_path, """
[track.csv]
file = "t.csv"
[track.npz]
file = "t.npz"
""")
    np.testing.assert_allclose(scene.tracks["csv"].sample(0.5).translation, [0.5, 1, 1.5])
    np.testing.assert_allclose(scene.tracks["csv"].sample(0.5).scale, [1.5] * 3)
    np.testing.assert_allclose(scene.tracks["npz"].sample(0.25).translation, [0, 1, 0])


def test_slerp_takes_the_short_way_and_matrices_round_trip():
    a = euler_xyz_to_quat([0, 10, 0])
    b = -euler_xyz_to_quat([0, 30, 0])  # the same rotation, other hemisphere
    np.testing.assert_allclose(quat_to_matrix(slerp(a, b, 0.5)), quat_to_matrix(euler_xyz_to_quat([0, 20, 0])), atol=1e-12)
    m = np.eye(4)
    m[:3, :3] = quat_to_matrix(euler_xyz_to_quat([20, 30, 40])) * 3.0
    t, q, s = decompose_matrix(m, "x")
    np.testing.assert_allclose(quat_to_matrix(q) * s, m[:3, :3], atol=1e-12)


@pytest.mark.parametrize(
    "text, message",
    [
        ('[track.t]\nkeys = [ { time = 5, translate = [0,0,0] }, { time = 2, translate = [1,0,0] } ]',
         "key 1 at time 0.2 s does not come after key 0"),
        ('[track.t]\nkeys = [ { time = 0, translate = [0,nan,0] } ]', "NaN"),
        ('[track.t]\nkeys = [ { time = 0, rotate = [0,0,0,0] } ]', "zero quaternion"),
        ('[track.t]\nkeys = [ { time = 0, scale = -1 } ]', "non-positive scale"),
        ('[track.t]\nkeys = [ { time = 0, translate = [0,0] } ]', "expected 3 numbers"),
        ('[track.t]\nkeys = [ { time = 0, spin = 3 } ]', "unknown key 'spin'"),
        ('[track.t]\ninterpolation = "bezier"\nkeys = [ { time = 0 } ]', "interpolation"),
        ('[track.t]\nkeys = [ { time = 0, matrix = [[1,1,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]] } ]', "shear"),
        ('[track.t]\nkeys = [ { time = 0, matrix = [[-1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]] } ]', "mirrors"),
        ('[track.t]\nfile = "t.csv"', "expected frame|time, tx, ty, tz"),
        ('[track.t]\nfile = "missing.csv"', "not found"),
    ],
)
def test_bad_tracks(tmp_path, text, message):
    (tmp_path / "t.csv").write_text("frame,x,y,z\n0,0,0,0\n")
    assert message in error_of(tmp_path, text)


# ------------------------------------------------------------------ colliders
def test_colliders_are_evaluated_in_world_space(tmp_path):
    scene = scene_with(tmp_path, """
[track.move]
keys = [ { time = 0, translate = [0, 0, 0] }, { time = 10, translate = [0, 2, 0], scale = 2 } ]
[collider.ball]
kind = "sphere"
center = [1, 0, 0]
radius = 0.5
track = "move"
thickness = 0.01
[collider.arm]
kind = "capsule"
start = [0, 0, 0]
end = [0, 1, 0]
radii = [0.2, 0.1]
[collider.floor]
kind = "plane"
point = [0, -1, 0]
[collider.box]
kind = "convex"
box = { center = [0, 0, 0], size = [2, 2, 2] }
""")
    start, end = scene.colliders.at(0.0), scene.colliders.at(1.0)
    np.testing.assert_allclose(start.sphere_center[0], [1, 0, 0])
    np.testing.assert_allclose(end.sphere_center[0], [2, 2, 0])  # scaled about the track origin
    assert end.sphere_radius[0] == pytest.approx(1.0)
    assert list(start.sphere_is_collider) == [True, False, False]
    assert start.capsule_spheres.tolist() == [[1, 2]] and start.sphere_radius[1:].tolist() == pytest.approx([0.2, 0.1])
    np.testing.assert_allclose(start.plane[0], [0, 1, 0, -1])  # n . x = d on the floor
    assert start.convex_plane_offsets.tolist() == [0, 1, 7]
    assert np.isnan(start.convex_friction).all()  # no friction given: the cloth's applies
    assert start.sphere_margin[0] == pytest.approx(0.01)


def test_mesh_collider_with_deformation(tmp_path):
    obj = tmp_path / "tri.obj"
    obj.write_text("v 0 0 0\nv 1 0 0\nv 0 0 1\nf 1 3 2\n")
    points = np.array([[[0, 0, 0], [1, 0, 0], [0, 0, 1]], [[0, 1, 0], [1, 1, 0], [0, 1, 1]]], float)
    np.savez(tmp_path / "deform.npz", frame=np.array([0.0, 10.0]), points=points)
    scene = scene_with(tmp_path, '[collider.m]\nkind = "mesh"\nmesh = "tri.obj"\ndeform = "deform.npz"\n')
    np.testing.assert_allclose(scene.colliders.at(0.5).mesh_points[:, 1], 0.5)
    assert scene.colliders.at(0.5).mesh_triangles.tolist() == [[0, 2, 1]]


@pytest.mark.parametrize(
    "text, message",
    [
        ('[collider.x]\nkind = "sphere"\nradius = -1.0', "must be positive"),
        ('[collider.x]\nkind = "capsule"\nstart = [0,0,0]\nend = [0,0,0]\nradius = 0.1', "degenerate capsule"),
        ('[collider.x]\nkind = "capsule"\nstart = [0,0,0]\nend = [0,0.1,0]\nradii = [1.0, 0.1]', "degenerate capsule"),
        ('[collider.x]\nkind = "convex"\nplanes = [[0,1,0,0],[0,-1,0,-1]]', "no interior"),
        ('[collider.x]\nkind = "cone"', "use one of sphere, capsule, plane, convex, mesh"),
        ('[collider.x]\nkind = "sphere"\nradius = 1.0\ncolour = "red"', "unknown key 'colour'"),
        ('[collider.x]\nkind = "sphere"\nradius = 1.0\ntrack = "nope"', "no [track.nope]"),
        ('[collider.x]\nkind = "mesh"\nmesh = "none.obj"', "file not found"),
        ('[collider.x]\nkind = "sphere"\nradius = 1.0\nfriction = -0.5', "must not be negative"),
    ],
)
def test_bad_colliders(tmp_path, text, message):
    assert message in error_of(tmp_path, text)


# ------------------------------------------------------------------ overrides and cloths
def test_overrides_reach_nested_tables_and_preset_strings():
    tables = {"solver": "production", "cloth": {"a": {"material": "cotton"}}}
    result = apply_overrides(tables, ["solver.frequency=600", "cloth.a.material.damping=0.2", "scene.frames=[1, 5]"])
    assert result["solver"] == {"preset": "production", "frequency": 600}
    assert result["cloth"]["a"]["material"] == {"preset": "cotton", "damping": 0.2}
    assert result["scene"]["frames"] == [1, 5]
    assert tables["solver"] == "production"  # the input is not changed


@pytest.mark.parametrize(
    "override, message",
    [
        ("solver.frequency", "expected KEY=VALUE"),
        ("scene.fps.x=1", "is a value, not a table"),
    ],
)
def test_bad_overrides(tmp_path, override, message):
    path = tmp_path / "scene.toml"
    path.write_text(HEADER)
    with pytest.raises(SceneError, match=message):
        load_scene(path, [override])


def test_cloth_placement_units_and_up_axis(tmp_path):
    scene = scene_with(tmp_path, "")
    cloth = scene.cloths[0]
    assert cloth.fabric.particle_count == 924 and cloth.material.areal_density == pytest.approx(0.15)
    path = tmp_path / "cm.toml"
    path.write_text(HEADER.replace("[scene]", '[scene]\nmeters_per_unit = 0.01\nup_axis = "Z"'))
    cm = load_scene(path)
    np.testing.assert_allclose(cm.gravity, [0, 0, -981.0])  # 9.81 m/s^2 down Z, in centimetres


@pytest.mark.parametrize(
    "text, message",
    [
        ('[cloth.d]\nfabric = "a.h5"\nmesh = "b.obj"', "give either 'fabric'"),
        ('[cloth.d]\nmesh = "b.obj"\ncook = { weld = "big" }', "key 'weld': expected a number"),
        ('[cloth.d]\nmesh = "b.obj"\ntrack = "walk"', "no [track.walk]"),
        ('[cloth.d]\nmesh = "b.obj"\nscale = 0.0', "must be positive"),
        ('[cloth.d]\nmesh = "b.obj"\nmotion = { stiffness = 2.0 }', "stiffness' must lie in [0, 1]"),
        ('[wind]\nvelocity = [1, 0]', "list of 3 finite numbers"),
        ('[output]\nattributes = ["normals"]', "choose from velocities, rest, stats, colliders"),
    ],
)
def test_bad_cloths_wind_and_output(tmp_path, text, message):
    (tmp_path / "b.obj").write_text((EXAMPLES / "cape" / "cape.obj").read_text())
    assert message in error_of(tmp_path, text)
