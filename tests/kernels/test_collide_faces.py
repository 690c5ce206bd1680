"""collide_faces (each face's deepest point against spheres and capsules) against
tests/reference/collide_faces.py: the deepest point's depth on random triangles and round
cones (tapered, straight, one sphere holding the other), and the whole kernel on a random
triangle soup among moving spheres and capsules, some corners pinned, float32 and float64."""

from __future__ import annotations

import numpy as np
import pytest

from clothtool._jit import kernel
from clothtool.solver.kernels.collide_faces import _capsule_terms, _edge_minimum, capsule_deepest, collide_faces
from tests.kernels._data import assert_close, particles
from tests.reference import collide_faces as ref
from tests.reference.collide_pose import pack_capsules, pack_spheres


@kernel
def _deepest(corners, capsule_data):
    """capsule_deepest of a (3,3) triangle against capsule 0, callable from Python."""
    p = corners
    return capsule_deepest(p[0, 0], p[0, 1], p[0, 2], p[1, 0], p[1, 1], p[1, 2], p[2, 0], p[2, 1], p[2, 2],
                           _capsule_terms(capsule_data, 0), False)


@kernel
def _edge(p, q, capsule_data):
    """_edge_minimum of the edge p q against capsule 0, callable from Python."""
    return _edge_minimum(p[0], p[1], p[2], q[0], q[1], q[2], _capsule_terms(capsule_data, 0))


def test_edge_minimum_matches_a_scalar_search():
    """The closed-form minimiser of the cone function along an edge against a bounded scalar
    search, on tapered and straight capsules: the same side distance (where the closest
    sphere lies inside the axis) at the same place along the edge."""
    rng = np.random.default_rng(5)
    checked = 0
    for trial in range(200):
        ends = random_capsule(rng, "straight" if trial % 3 == 0 else "tapered")
        capsule_data = np.ascontiguousarray(pack_capsules(ends, ends, np.array([[0, 1]]), np.array([[0.0, 0.5]])))
        p, q = rng.uniform(-0.2, 0.2, 3) + [0.0, 0.0, 0.15], rng.uniform(-0.2, 0.2, 3) + [0.0, 0.0, 0.15]
        got, lam = _edge(p, q, capsule_data)
        want, want_lam = ref._edge_minimum(*p, *q, ref._capsule_terms(capsule_data, 0))
        assert np.isfinite(got) == np.isfinite(want), (got, want)
        if np.isfinite(want):
            checked += 1
            assert abs(got - want) <= 1e-9, (got, want)
            assert abs(lam - want_lam) <= 1e-4, (lam, want_lam)
    assert checked > 100


def random_capsule(rng, kind: str) -> np.ndarray:
    """End spheres (2,4) float64: a tapered or straight capsule about 0.3 long, or one whose
    bigger sphere holds the smaller (a ball)."""
    ra = rng.uniform(0.03, 0.1)
    rb = {"tapered": rng.uniform(0.03, 0.1), "straight": ra, "nested": ra * 0.3}[kind]
    b = (rng.uniform(-0.3, 0.3), rng.uniform(-0.3, 0.3), 0.3) if kind != "nested" else (0.01, 0.0, 0.02)
    return np.array([[0.0, 0.0, 0.0, ra], [*b, rb]])


@pytest.mark.parametrize("dtype", [np.float32, np.float64], ids=["f32", "f64"])
@pytest.mark.parametrize("kind", ["tapered", "straight", "nested"])
def test_deepest_point_matches_the_searched_minimum(dtype, kind):
    """Where the reference's least distance over the triangle is negative the kernel finds it
    (to float rounding; its point is at least as deep, the search's grid being finite); where
    it is positive the kernel reports no point inside."""
    rng = np.random.default_rng({"tapered": 1, "straight": 2, "nested": 3}[kind])
    inside = 0
    for _ in range(120):
        ends = random_capsule(rng, kind)
        capsule_data = np.ascontiguousarray(pack_capsules(ends, ends, np.array([[0, 1]]), np.array([[0.0, 0.5]])), dtype)
        corners = rng.uniform(-0.12, 0.12, (3, 3)) + [rng.uniform(0, 0.1), 0.0, rng.uniform(-0.1, 0.4)]
        corners = np.ascontiguousarray(corners, dtype)
        want, *_ = ref.capsule_deepest(*corners.ravel(), np.asarray(capsule_data[0], np.float64))
        got, *weights = _deepest(corners, capsule_data)
        tolerance = 2e-6 if dtype == np.float32 else 1e-9
        if want >= 0.0:
            assert not got < -tolerance, (got, want)
            continue
        inside += 1
        assert abs(got - want) <= tolerance, (got, want)
        # the weights are the point's: its distance (numpy's round cone) is the depth found
        assert min(weights) >= -1e-6 and abs(sum(weights) - 1.0) <= 1e-6  # 1 - u - v rounds
        point = np.asarray(weights, np.float64) @ corners.astype(np.float64)
        at = ref.hull_distance(point, ends[0, :3], ends[0, 3], ends[1, :3], ends[1, 3])
        assert abs(at - want) <= 10 * tolerance, (at, want)
    assert inside > 25


@pytest.mark.parametrize("dtype", [np.float32, np.float64], ids=["f32", "f64"])
def test_collide_faces_matches_reference(dtype):
    """A soup of 40 triangles among two spheres and two capsules (one tapered) that moved a
    little over the iteration: every face's deepest point in each collider is pushed out with
    friction and the collision mass scale, its correction shared out to the movable corners;
    pinned particles stay put."""
    rng = np.random.default_rng(7)
    start = np.array([[0.25, 0.0, 0.0, 0.12], [-0.3, 0.1, 0.2, 0.09], [0.0, 0.3, -0.3, 0.1], [0.3, 0.25, -0.3, 0.06],
                      [-0.3, -0.3, -0.2, 0.08], [0.1, -0.35, 0.3, 0.08]])
    end = start + np.hstack([rng.normal(0, 0.01, (6, 3)), np.zeros((6, 1))])
    as_real = lambda x: np.ascontiguousarray(x, dtype)  # noqa: E731
    spheres = as_real(pack_spheres(start, end, np.array([0, 1], np.int32), np.array([[0.01, 0.5], [0.0, 0.2]])))
    capsules = as_real(pack_capsules(start, end, np.array([[2, 3], [4, 5]], np.int32), np.array([[0.005, 0.8], [0.0, 0.3]])))
    cur0, prev0 = particles(rng, 60, extent=0.45, speed=0.005)
    cur0, prev0 = as_real(cur0), as_real(prev0)
    faces = rng.integers(0, 60, (40, 3)).astype(np.int32)
    faces = faces[(faces[:, 0] != faces[:, 1]) & (faces[:, 1] != faces[:, 2]) & (faces[:, 0] != faces[:, 2])]
    cur = cur0.copy()
    collide_faces(faces, spheres, capsules, prev0, dtype(20.0), dtype(1.0), cur)
    want = ref.collide_faces(faces, spheres, capsules, prev0, 20.0, 1.0, cur0)
    assert_close(cur, want, 2e-4 if dtype == np.float32 else 2e-6, "cur")
    fixed = (prev0[:, 3] == 0) | (cur0[:, 3] == 0)
    np.testing.assert_array_equal(cur[fixed], cur0[fixed])
    assert (np.abs(cur - cur0)[:, :3].max(axis=1) > 1e-3).sum() > 10  # contacts happened
    # and afterwards no face is inside a collider by more than the next corrections' rounding
    again = cur.copy()
    collide_faces(faces, spheres, capsules, prev0, dtype(20.0), dtype(1.0), again)
    assert np.abs(again - cur)[:, :3].max() < np.abs(cur - cur0)[:, :3].max()


def test_far_faces_are_left_alone():
    """Faces beyond every collider's box: not a bit changes, in either precision."""
    rng = np.random.default_rng(8)
    ends = np.array([[0.0, 0.0, 0.0, 0.05], [0.0, 0.3, 0.0, 0.05]])
    for dtype in (np.float32, np.float64):
        capsules = np.ascontiguousarray(pack_capsules(ends, ends, np.array([[0, 1]]), np.array([[0.0, 0.5]])), dtype)
        spheres = np.ascontiguousarray(pack_spheres(ends, ends, np.array([0], np.int32), np.array([[0.0, 0.5]])), dtype)
        cur0, prev = particles(rng, 30, extent=0.3, speed=0.01)
        cur0[:, 0] += 1.0
        cur0, prev = cur0.astype(dtype), prev.astype(dtype)
        cur = cur0.copy()
        collide_faces(rng.integers(0, 30, (20, 3)).astype(np.int32), spheres, capsules, prev, dtype(20.0), dtype(1.0), cur)
        assert cur.tobytes() == cur0.tobytes()


def test_a_face_pinned_at_its_contact_moves_its_free_corner_a_bounded_amount():
    """A sphere pressing into a face next to its two pinned corners: c w / sum(w^2) would move
    the free corner (weight ~0.03) some thirty times the depth; the share is capped at
    (1 + sqrt 3) / 2, the most it is when all corners move, and pinned corners stay put."""
    for dtype in (np.float32, np.float64):
        cur = np.array([[0.0, 0.0, 0.0, 0.0], [0.2, 0.0, 0.0, 0.0], [0.0, 0.0, 0.4, 1.0]], dtype)
        prev = cur.copy()
        depth, radius = 0.004, 0.05
        centre = (0.1, radius - depth, 0.012)  # over the edge between the pinned corners
        ends = np.array([centre + (radius,)] * 2)
        spheres = np.ascontiguousarray(pack_spheres(ends, ends, np.array([0], np.int32), np.array([[0.0, 0.5]])), dtype)
        after = cur.copy()
        collide_faces(np.array([[0, 1, 2]], np.int32), spheres, spheres[:0, :0].reshape(0, 24), prev, dtype(0.0),
                      dtype(1.0), after)
        np.testing.assert_array_equal(after[:2], cur[:2])
        moved = np.linalg.norm(after[2, :3] - cur[2, :3])
        assert 0.99 * depth < moved <= (1 + np.sqrt(3)) / 2 * depth * (1 + 1e-5), moved
        assert after[2, 1] < 0.0  # pushed away from the sphere, which is above
