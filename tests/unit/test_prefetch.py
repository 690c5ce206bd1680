"""Sampling ahead: colliders evaluated for a bake's frame times together, and a cloth's track
path sampled at all of a bake's iteration ends at once, give each time the same bits as
evaluating that time alone, and closed-form values."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from clothtool.bake import _track_path, _track_times
from clothtool.collision.colliders import ColliderArrays
from clothtool.loading import load_scene
from clothtool.scene.tracks import euler_xyz_to_quat, quat_to_matrix
from clothtool.solver import frame as frame_module
from clothtool.solver.frame import FrameHistory, FrameInertia, FrameMotionAhead, FramePath, Pose, PoseRows
from clothtool.solver.iteration import FramePlan
from tests.conftest import EXAMPLES

SCENE = f"""
[scene]
fps = 10.0
frames = [0, 10]
[cloth.c]
mesh = "{(EXAMPLES / 'cape' / 'cape.obj').as_posix()}"
cook = {{ pin_attr = "color_r" }}
track = "turn"
[track.turn]
interpolation = "cubic"
keys = [
  {{ time = 0, translate = [0, 0, 0] }},
  {{ time = 3, translate = [1, 0.5, 0], rotate_euler = [30, 10, 0], scale = 1.5 }},
  {{ time = 7, translate = [2, 0, 1], rotate_euler = [-20, 60, 5], scale = 0.5 }},
  {{ time = 10, translate = [3, 1, 0], rotate_euler = [0, 90, 0], scale = 1 }},
]
[track.slide]
keys = [ {{ time = 0, translate = [0, 0, 0] }}, {{ time = 10, translate = [0, 2, 0], scale = 2 }} ]
[collider.ball]
kind = "sphere"
center = [1, 0, 0]
radius = 0.5
track = "slide"
[collider.leg]
kind = "capsule"
start = [0, 0, 0]
end = [0, -1, 0]
radii = [0.2, 0.1]
track = "turn"
[collider.floor]
kind = "plane"
point = [0, -1, 0]
track = "turn"
[collider.box]
kind = "convex"
box = {{ center = [0, 0, 0], size = [2, 1, 2] }}
track = "turn"
[collider.tri]
kind = "mesh"
mesh = "tri.obj"
track = "turn"
"""


@pytest.fixture
def scene(tmp_path: Path):
    (tmp_path / "tri.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 0 1\nf 1 3 2\n")
    path = tmp_path / "scene.toml"
    path.write_text(SCENE)
    return load_scene(path)


def _fields(arrays) -> dict:
    """The arrays (the compared fields: not ``source``, which says where they come from)."""
    return {field.name: getattr(arrays, field.name) for field in dataclasses.fields(arrays) if field.compare}


def test_prefetched_colliders_are_the_bits_of_one_time_alone(scene):
    times = [scene.frame_time(frame) for frame in range(scene.start_frame, scene.end_frame + 1)]
    alone = [_fields(scene.colliders.at(t)) for t in times]  # nothing prefetched: one time each
    scene.colliders.prefetch(times)
    for t, expected in zip(times, alone):
        got = _fields(scene.colliders.at(t))
        for name, array in expected.items():
            assert got[name].dtype == array.dtype and got[name].shape == array.shape, name
            assert np.array_equal(got[name], array, equal_nan=name.endswith("friction")), (t, name)
    # a time between the prefetched ones is evaluated when asked: the ball 55% along its slide
    np.testing.assert_allclose(scene.colliders.at(0.55).sphere_center[0], [1.55, 1.1, 0.0], rtol=1e-6)


def test_prefetched_collider_transforms_are_the_bits_of_one_time_alone(scene):
    """The cache's collider transforms at a prefetched time come from the prefetch's track
    matrices: the same bits as a time evaluated alone, for every kind on a scaled, turning
    cubic track and a scaled slide; the shape matrices are made once and read-only."""
    times = [scene.frame_time(frame) for frame in range(scene.start_frame, scene.end_frame + 1)]
    alone = [scene.colliders.xforms(t) for t in times]  # nothing prefetched
    scene.colliders.prefetch(times)
    for t, expected in zip(times, alone):
        for got, want in zip(scene.colliders.xforms(t), expected, strict=True):
            assert got.flags.c_contiguous and np.array_equal(got, want), t
    leg = next(c for c in scene.colliders.colliders if c.kind == "capsule")
    assert leg.shape_matrix() is leg.shape_matrix() and not leg.shape_matrix().flags.writeable
    # the capsule's canonical +X axis maps onto its start-to-end direction, centred
    np.testing.assert_allclose(leg.shape_matrix()[:3, :3] @ [1.0, 0.0, 0.0], [0.0, -1.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(leg.shape_matrix()[:3, 3], [0.0, -0.5, 0.0], atol=1e-12)


def test_prefetched_colliders_match_closed_forms(scene):
    scene.colliders.prefetch([0.0, 0.5, 1.0])
    middle = scene.colliders.at(0.5)
    # the ball slides up 2 units over the scene and doubles in scale: half way, 1 up, scale 1.5
    np.testing.assert_allclose(middle.sphere_center[0], [1.5, 1.0, 0.0], rtol=1e-6)
    assert middle.sphere_radius[0] == pytest.approx(0.75)
    # at 1.0 s (frame 10) the turn track is at its last key
    end = scene.colliders.at(1.0)
    rotation = quat_to_matrix(euler_xyz_to_quat([0, 90, 0]))
    np.testing.assert_allclose(end.sphere_center[2], rotation @ [0, -1, 0] + [3, 1, 0], atol=1e-6)
    # the floor turned with the track: its normal is the rotated +Y
    np.testing.assert_allclose(end.plane[0, :3], rotation @ [0, 1, 0], atol=1e-6)
    np.testing.assert_allclose(end.mesh_points, np.array([[0, 0, 0], [1, 0, 0], [0, 0, 1]]) @ rotation.T + [3, 1, 0],
                               atol=1e-6)
    assert middle.mesh_triangles.tolist() == [[0, 2, 1]] and middle.convex_plane_offsets.tolist() == [0, 1, 7]


def test_track_path_planned_times_are_the_bits_of_one_time_alone(scene):
    track = scene.cloths[0].track
    planned = _track_times(scene)
    path, alone = _track_path(track, planned), _track_path(track)
    # the first frame's start and one iteration before it (the solver's start pose and
    # motion), then iteration ends as the solver plans them: the last of each frame ends on
    # the frame's time
    iterations = FramePlan.iterations_for(1.0 / scene.fps, scene.solver.frequency)
    frame_dt = 1.0 / scene.fps
    start = scene.frame_time(scene.start_frame - scene.preroll)
    plan = FramePlan(1, start, frame_dt, iterations, frame_dt / iterations, 0.0)
    assert planned[:2] == [plan.time - plan.h, plan.time]
    ends = planned[2:]
    assert len(ends) == iterations * (scene.end_frame - scene.start_frame + scene.preroll)
    assert ends[iterations - 1] == scene.frame_time(scene.start_frame - scene.preroll + 1)
    for times in (planned[:2], ends[iterations:2 * iterations]):
        for got, expected in zip(path.poses(times), alone.poses(times)):
            assert np.array_equal(got.rotation, expected.rotation) and np.array_equal(got.translation, expected.translation)
    unplanned = path(0.123456)  # sampled when asked
    np.testing.assert_array_equal(unplanned.translation, alone(0.123456).translation)


def test_frame_path_samples_planned_times_once():
    calls = []

    def many(times):
        calls.append(len(times))
        return [Pose(np.eye(3), np.array([t, 0.0, 0.0])) for t in times]

    path = FramePath(lambda t: many(np.array([t]))[0], many, planned=[0.1, 0.2, 0.3])
    assert [p.translation[0] for p in path.poses([0.1, 0.2])] == [0.1, 0.2]
    assert path(0.3).translation[0] == 0.3
    assert calls == [3]  # the planned times from the first asked for, together, at the first request
    assert path.poses([0.3, 0.4])[1].translation[0] == 0.4
    assert calls == [3, 2]  # a time not planned: sampled with the others asked together


def _turning_path(planned=()):
    """A frame spinning about Z and moving along X with an acceleration (closed-form poses)."""

    def at(t: float) -> Pose:
        angle = 0.7 * t + 0.3 * t * t
        c, s = np.cos(angle), np.sin(angle)
        return Pose(np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]), np.array([t * t, 0.5 * t, 0.0]))

    return FramePath(at, lambda times: [at(float(t)) for t in times], planned)


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_frame_motion_ahead_gives_the_bits_of_advance_many(dtype):
    h, k = 1.0 / 240.0, 10
    inertia = FrameInertia(0.8, 0.6, 0.05, 0.1)
    gravity = np.array([0.0, -9.81, 0.0])
    ends = [h * (i + 1) for i in range(8 * k)]
    path = _turning_path(ends)
    targets = path.poses(ends[:k])
    history = FrameHistory(path(-h))
    history.now = path(0.0)
    ahead = _ahead(history, path, ends, 5 * k, gravity, h, inertia, 90.0)
    scales = np.linspace(0.9, 1.0, k)
    for frame in range(5):
        expected = history.advance_many(targets, scales, gravity, h, inertia, 90.0, dtype)
        got = ahead.terms(history, ends[frame * k:(frame + 1) * k], scales, h, dtype)
        for name in ("m_cur", "m_prev", "bias", "motion_matrix", "motion_offset", "to_local", "rotations", "translations",
                     "pose_pairs"):
            a, b = getattr(got, name), getattr(expected, name)
            assert a.dtype == b.dtype and np.array_equal(a, b), (frame, name)
        # a wind in the frame: the chain's one product gives each frame's rows bit for bit
        wind = np.array([3.0, -0.7, 1.3]) * (frame + 1)
        assert got.ahead is not None and expected.ahead is None
        assert got.in_frame(wind).tobytes() == expected.in_frame(wind).tobytes()
        for air in (got.in_frame(wind, np.float32), expected.in_frame(wind, np.float32)):
            assert air.dtype == np.float32 and air.flags.c_contiguous
            assert air.tobytes() == (expected.to_local @ wind).astype(np.float32).tobytes()
        assert len(got.poses) == k + 1 and got.poses[0] is history.now  # the chain's own poses ...
        for p, q in zip(got.poses, expected.poses):  # ... at the targets' times
            assert np.array_equal(p.rotation, q.rotation) and np.array_equal(p.translation, q.translation)
        history.before, history.now = got.poses[-2:]
        targets = path.poses(ends[(frame + 1) * k:(frame + 2) * k])
    # past its chain, at another h, from a history off the chain or at other times: None
    assert ahead.terms(history, ends[5 * k:6 * k], scales, h, dtype) is None
    again = _ahead(history, path, ends[5 * k:], 2 * k, gravity, h, inertia, 90.0)
    assert again.terms(history, ends[5 * k:6 * k], scales, 2.0 * h, dtype) is None
    assert again.terms(FrameHistory(path(0.5)), ends[5 * k:6 * k], scales, h, dtype) is None
    assert again.terms(history, ends[5 * k + 1:6 * k + 1], scales, h, dtype) is None
    assert again.terms(history, ends[5 * k:6 * k], scales, h, dtype) is not None


def _ahead(history, path, ends, count, *motion) -> FrameMotionAhead:
    """The frame motion computed ahead from ``history`` over the path's next ``count`` planned
    poses from ``ends[0]`` on (as the solver builds it)."""
    following, times = path.following_rows(ends[0], count)
    assert times == ends[:count]
    chain = PoseRows(np.concatenate([history.before.rotation[None], history.now.rotation[None], following.rotations]),
                     np.concatenate([history.before.translation[None], history.now.translation[None],
                                     following.translations]), {0: history.before, 1: history.now})
    return FrameMotionAhead(chain, times, *motion)


def test_frame_motion_ahead_matches_world_space_verlet():
    """With full inertia, no drag and no damping, the local-frame step of a particle at rest in
    the world is world-space Verlet: it stays where it is (module docstring of solver.frame)."""
    h = 0.01
    path = _turning_path([h * (i + 1) for i in range(20)])
    history = FrameHistory(path(-h))
    history.now = path(0.0)
    ahead = _ahead(history, path, [h * (i + 1) for i in range(20)], 20, np.zeros(3), h, FrameInertia(), 1.0)
    terms = ahead.terms(history, [h * (i + 1) for i in range(4)], np.ones(4), h, np.float64)
    world = np.array([0.3, -0.2, 0.5])
    before, now = history.before.to_local(world), history.now.to_local(world)
    for i in range(4):
        x = now + terms.m_cur[i] @ now + terms.m_prev[i] @ before + terms.bias[i]  # integrate_affine
        np.testing.assert_allclose(terms.poses[i + 1].to_world(x), world, atol=1e-12)
        before, now = now, x


def test_frame_path_window_slides_and_keeps_the_poses_it_holds(monkeypatch):
    monkeypatch.setattr(frame_module, "PLANNED_CHUNK", 8)
    sampled = []
    plain = _turning_path()

    def many(times):
        sampled.append(len(times))
        return [plain(float(t)) for t in times]

    planned = [0.1 * (i + 1) for i in range(30)]
    path = FramePath(plain, many, planned)
    first = path.poses(planned[:5])
    assert sampled == [8]
    following = path.following(planned[3], 10)  # 10 from the 4th: the window slides on by 5
    assert sampled == [8, 5] and len(following) == 10
    assert following[0] is first[3] and following[1] is first[4]  # kept, not sampled again
    assert path.poses(planned[3:5]) == [following[0], following[1]]
    assert len(path.following(planned[25], 10)) == 5  # fewer at the end of the planned times
    np.testing.assert_array_equal(path(planned[29]).translation, plain(planned[29]).translation)


def test_a_bake_samples_a_tracked_cloths_frame_once(scene, monkeypatch):
    """The solver's start pose, the pose one iteration before it and every iteration end
    come from one vectorised sample of the track (each extra call costs ~0.3 ms)."""
    from clothtool.bake import bake

    calls = []
    sample = FramePath._sample

    def counted(path, times):
        calls.append(len(times))
        return sample(path, times)

    monkeypatch.setattr(FramePath, "_sample", counted)
    bake(scene, "null")
    iterations = FramePlan.iterations_for(1.0 / scene.fps, scene.solver.frequency)
    assert calls == [2 + iterations * (scene.end_frame - scene.start_frame + scene.preroll)]


@pytest.mark.parametrize("stacked", [True, False])
def test_following_rows_are_the_held_poses_as_they_slide(monkeypatch, stacked):
    """``following_rows`` gives the held poses (the very objects ``poses`` and ``following``
    give, made when first asked for) with their stacked arrays and times, while the window
    slides (kept rows and new ones), whether the path samples PoseRows or lists of poses."""
    monkeypatch.setattr(frame_module, "PLANNED_CHUNK", 8)
    plain = _turning_path()

    def many(times):
        poses = [plain(float(t)) for t in times]
        if not stacked:
            return poses
        return PoseRows(np.stack([p.rotation for p in poses]), np.stack([p.translation for p in poses]))

    planned = [0.1 * (i + 1) for i in range(30)]
    path = FramePath(plain, many, planned)
    for start, count in ((0, 5), (3, 10), (12, 8), (25, 10)):
        rows, times = path.following_rows(planned[start], count)
        assert len(rows) == min(count, 30 - start) and times == planned[start:start + len(rows)]
        assert all(a is b for a, b in zip(rows, path.following(planned[start], count)))
        assert all(a is b for a, b in zip(rows, path.poses(times)))
        assert rows.rotations.shape == (len(rows), 3, 3) and rows.translations.shape == (len(rows), 3)
        for index, (pose, rotation, translation) in enumerate(zip(rows, rows.rotations, rows.translations)):
            assert np.array_equal(pose.rotation, rotation) and np.array_equal(pose.translation, translation)
            expected = plain(planned[start + index])
            assert np.array_equal(rotation, expected.rotation) and np.array_equal(translation, expected.translation)
    assert len(path.following_rows(0.123, 3)[0]) == 0  # not a planned time


def test_pose_rows_make_each_pose_once_and_slices_share_them():
    rotations, translations = np.stack([np.eye(3)] * 5), np.arange(15.0).reshape(5, 3)
    known = Pose(np.eye(3), np.array([0.0, 1.0, 2.0]))
    rows = PoseRows(rotations, translations, {0: known})
    assert rows[0] is known and rows[-1] is rows[4] and rows[1:4][2] is rows[3]
    np.testing.assert_array_equal(rows[2].translation, [6.0, 7.0, 8.0])
    assert rows[3:][0] is rows[3] and len(rows[3:]) == 2 and list(rows[3:]) == [rows[3], rows[4]]
    assert set(rows[1:].known()) == {1, 2, 3}  # rows 2-4 were made above (row 1 never), numbered from the slice
    with pytest.raises(IndexError):
        rows[5]
    assert PoseRows.of([known])[0] is known


def test_pose_pairs_are_each_iterations_start_and_end_pose():
    path = _turning_path()
    poses = [path(0.1 * i) for i in range(5)]
    pairs = frame_module.pose_pairs(np.stack([p.rotation for p in poses]), np.stack([p.translation for p in poses]))
    assert pairs.shape == (4, 8, 3)
    for i in range(4):
        np.testing.assert_array_equal(pairs[i, 0:3], poses[i].rotation)
        np.testing.assert_array_equal(pairs[i, 3], poses[i].translation)
        np.testing.assert_array_equal(pairs[i, 4:7], poses[i + 1].rotation)
        np.testing.assert_array_equal(pairs[i, 7], poses[i + 1].translation)


@pytest.mark.parametrize("fps, frequency, preroll", [(10.0, 240.0, 0), (24.0, 300.0, 2), (30.0, 10.0, 1)])
def test_track_times_are_the_plans_iteration_ends(scene, fps, frequency, preroll):
    """The planned times, worked out for all frames at once, are the very floats the frames'
    plans give (a FramePath finds a pose by its time)."""
    scene = dataclasses.replace(scene, fps=fps, preroll=preroll,
                                solver=dataclasses.replace(scene.solver, frequency=frequency))
    frame_dt = 1.0 / scene.fps
    iterations = FramePlan.iterations_for(frame_dt, scene.solver.frequency)
    first = scene.start_frame - scene.preroll + 1
    start = scene.frame_time(first - 1)
    expected = [start - frame_dt / iterations, start]
    for frame in range(first, scene.end_frame + 1):
        plan = FramePlan(frame, scene.frame_time(frame - 1), frame_dt, iterations, frame_dt / iterations, 0.0,
                         scene.frame_time(frame))
        expected += [plan.iteration_end(index) for index in range(iterations)]
    assert _track_times(scene) == expected


@pytest.mark.parametrize("frame_dt, iterations", [(1.0 / 24.0, 13), (1.0 / 30.0, 1), (0.1, 7)])
def test_iteration_ends_are_each_iteration_end(frame_dt, iterations):
    for frame, time in ((1, 0.0), (17, 16 * frame_dt), (400, 399 * frame_dt)):
        plan = FramePlan(frame, time, frame_dt, iterations, frame_dt / iterations, 0.0, frame * frame_dt)
        assert plan.iteration_ends() == [plan.iteration_end(index) for index in range(iterations)]


FIXED_SCENE = f"""
[scene]
fps = 10.0
frames = [0, 6]
[cloth.c]
mesh = "{(EXAMPLES / 'cape' / 'cape.obj').as_posix()}"
cook = {{ pin_attr = "color_r" }}
[track.still]
keys = [ {{ time = 0, translate = [0, -0.5, 0], rotate_euler = [0, 30, 0] }} ]
[collider.ball]
kind = "sphere"
center = [0.1, -0.3, 0]
radius = 0.2
[collider.leg]
kind = "capsule"
start = [0, 0, 0]
end = [0, -1, 0]
radii = [0.1, 0.08]
track = "still"
"""


def test_colliders_fixed_in_time_are_one_set_of_arrays(tmp_path):
    path = tmp_path / "scene.toml"
    path.write_text(FIXED_SCENE)
    colliders = load_scene(path).colliders
    first = colliders.at(0.0)
    alone = _fields(first)
    colliders.prefetch([0.0, 0.1, 0.2])
    assert colliders.at(0.2) is first and colliders.at(0.35) is first
    # the same bits as a prefetched time would have
    fresh = load_scene(path).colliders
    fresh.prefetch([0.0, 0.1, 0.2])
    for name, array in _fields(fresh.at(0.1)).items():
        assert np.array_equal(array, alone[name], equal_nan=name.endswith("friction")), name


def test_moving_colliders_are_arrays_of_their_time(scene):
    assert scene.colliders.at(0.0) is not scene.colliders.at(0.1)


def test_the_collide_stage_copies_fixed_colliders_once(tmp_path, monkeypatch):
    from clothtool.bake import BakeOptions, bake
    from clothtool.io.memory import MemoryCacheWriter
    from clothtool.solver.collide import CollideStage

    path = tmp_path / "scene.toml"
    path.write_text(FIXED_SCENE)
    copies = []
    original = CollideStage._copy_spheres
    monkeypatch.setattr(CollideStage, "_copy_spheres", lambda self, *a: (copies.append(1), original(self, *a)))
    baked = MemoryCacheWriter()
    bake(load_scene(path), baked, BakeOptions())
    assert len(copies) == 1
    monkeypatch.setattr(CollideStage, "_copy_spheres", original)
    # and the bake's bits are those of a stage that copies them every frame
    monkeypatch.setattr(CollideStage, "begin_frame", _copying_every_frame(CollideStage.begin_frame))
    every_frame = MemoryCacheWriter()
    bake(load_scene(path), every_frame, BakeOptions())
    assert baked.frames.keys() == every_frame.frames.keys()
    for frame, points in baked.frames.items():
        assert np.array_equal(points[0], every_frame.frames[frame][0]), frame


def _copying_every_frame(begin_frame):
    def begin(self, plan):
        self._copied = (None, None)
        return begin_frame(self, plan)

    return begin


def test_collider_arrays_of_fields_is_what_init_makes(scene):
    """ColliderArrays.of (the prefetch's rows: no generated __init__) gives the object
    ColliderArrays(**fields) gives: every field, frozen, no field missing."""
    scene.colliders.prefetch([0.0, 0.1])
    made = scene.colliders.at(0.1)
    fields = {field.name: getattr(made, field.name) for field in dataclasses.fields(made)}
    assert vars(made).keys() == fields.keys()
    initialised = ColliderArrays(**fields)
    for name, value in fields.items():
        assert getattr(initialised, name) is value
    with pytest.raises(dataclasses.FrozenInstanceError):
        made.sphere_center = None


def test_face_measure_cones_of_prefetched_rows_are_those_of_one_time_alone(scene):
    """The face measure's round cones (penetration.ConeRecords: made for every prefetched row
    at once, kept while the same colliders come again) are those made from one time's
    colliders alone: the ball (both ends its centre) then the tapered leg, radii grown by the
    margins; and the measure gives the same figures with them."""
    from clothtool.solver.penetration import ConeRecords, face_penetration

    times = [scene.frame_time(frame) for frame in range(scene.start_frame, scene.end_frame + 1)]
    alone = [ConeRecords()(scene.colliders.at(t)) for t in times]  # nothing prefetched: no stack
    first = scene.colliders.at(times[0])
    margin = np.concatenate([first.sphere_margin[first.sphere_is_collider], first.capsule_margin]).astype(np.float64)
    np.testing.assert_array_equal(alone[0][:, 8:11], [[1, 0, 0], [0, 0, 0]])
    np.testing.assert_array_equal(alone[0][:, 12:15], [[1, 0, 0], [0, -1, 0]])
    np.testing.assert_allclose(alone[0][:, [11, 15]], np.array([[0.5, 0.5], [0.2, 0.1]]) + margin[:, None], rtol=1e-7)
    scene.colliders.prefetch(times)
    cones = ConeRecords()
    points = np.array([[0.0, -0.5, -0.3], [0.3, -0.5, 0.3], [-0.3, -0.5, 0.3], [1.0, 0.5, 0.0]])
    triangles = np.array([[0, 1, 2], [1, 3, 2]], np.int32)
    for t, expected in zip(times, alone):
        colliders = scene.colliders.at(t)
        assert colliders.source is not None
        records = cones(colliders)
        assert cones(colliders) is records  # the same colliders again: kept
        np.testing.assert_array_equal(records, expected)
        kept = face_penetration(points, triangles, colliders, 1.0, 0.01, cones)
        assert kept == face_penetration(points, triangles, colliders, 1.0, 0.01)
