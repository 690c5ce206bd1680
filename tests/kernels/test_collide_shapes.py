"""collide_shapes kernels (spheres, tapered capsules, convexes, times of impact) against
tests/reference/collide_shapes.py on random inputs."""

from __future__ import annotations

import numpy as np
import pytest

from clothtool.solver.kernels.collide_shapes import (
    CAPSULE_COLUMNS,
    capsule_at,
    capsule_axis,
    capsule_distance,
    capsule_time_of_impact,
    convex_distance,
    perpendicular,
    rotate_between,
    round_cone_distance,
    sphere_distance,
    sphere_time_of_impact,
)
from tests.kernels._data import F32, f32
from tests.reference import collide_shapes as ref


def unit(rng, n=None):
    v = rng.normal(size=3 if n is None else (n, 3))
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def test_perpendicular_is_the_documented_unit_vector():
    rng = np.random.default_rng(1)
    for u in [*unit(rng, 30), np.array([1.0, 0, 0]), np.array([0, 0, -1.0]), np.array([0.6, 0.8, 0.0])]:
        u = f32(u)
        got = np.array(perpendicular(*u))
        np.testing.assert_allclose(got, ref.perpendicular(*u), atol=1e-6)
        assert abs(got @ u) < 1e-6 and abs(np.linalg.norm(got) - 1) < 1e-6


def test_sphere_distance_matches_reference():
    rng = np.random.default_rng(2)
    for _ in range(200):
        p, c = f32(rng.uniform(-1, 1, 3)), f32(rng.uniform(-1, 1, 3))
        r = F32(rng.uniform(0.05, 1.0))
        np.testing.assert_allclose(sphere_distance(*p, *c, r), ref.sphere_distance(*p, *c, r), atol=2e-6)
    assert sphere_distance(F32(1), F32(2), F32(3), F32(1), F32(2), F32(3), F32(0.5)) == (-0.5, 0.0, 1.0, 0.0)


def random_capsule(rng):
    a, b = rng.uniform(-0.5, 0.5, 3), rng.uniform(-0.5, 0.5, 3)
    ra, rb = rng.uniform(0.02, 0.3, 2)
    return f32(a), F32(ra), f32(b), F32(rb)


@pytest.mark.parametrize("seed", range(4))
def test_round_cone_distance_matches_the_hull_support_function(seed):
    """Points all around tapered capsules (inside, on the cone, beyond the caps): the signed
    distance, normal and sigma agree with the brute-force hull distance."""
    rng = np.random.default_rng(seed)
    checked = 0
    for _ in range(40):
        a, ra, b, rb = random_capsule(rng)
        p = f32(a + rng.uniform(-0.3, 1.3) * (b - a) + rng.normal(0, 0.25, 3))
        d, nx, ny, nz, sigma = round_cone_distance(*p, *a, ra, *b, rb)
        rd, rnx, rny, rnz, rsigma = ref.round_cone_distance(*p, *a, ra, *b, rb)
        assert abs(d - rd) <= 3e-6, (d, rd)
        if abs(rd) > 1e-3:  # the normal is defined away from the surface's medial set
            np.testing.assert_allclose([nx, ny, nz], [rnx, rny, rnz], atol=2e-3)
            assert abs(sigma - rsigma) <= 2e-3, (sigma, rsigma)
            checked += 1
    assert checked > 30


def test_round_cone_distance_is_exact_on_a_known_tapered_capsule():
    """Spheres (0,0,0) r=2 and (10,0,0) r=1: sin(alpha) = 0.1. A point on the side line's
    normal through the middle, and points beyond each cap."""
    a, b = f32([0, 0, 0]), f32([10, 0, 0])
    sin, cos = 0.1, np.sqrt(0.99)
    n = np.array([sin, cos, 0.0])
    # the side touches sphere a at ra * n and sphere b at b + rb * n
    surface = 0.5 * (2 * n + (np.array([10.0, 0, 0]) + n))
    for offset in (0.3, -0.2):
        p = f32(surface + offset * n)
        d, *normal, sigma = round_cone_distance(*p, *a, F32(2), *b, F32(1))
        assert abs(d - offset) < 1e-5
        np.testing.assert_allclose(normal, n, atol=1e-5)
        assert abs(sigma - 0.5) < 1e-4
    d, *_, sigma = round_cone_distance(F32(-3), F32(0), F32(0), *a, F32(2), *b, F32(1))
    assert (abs(d - 1.0) < 1e-6, sigma) == (True, 0.0)
    d, *_, sigma = round_cone_distance(F32(12), F32(0), F32(0), *a, F32(2), *b, F32(1))
    assert (abs(d - 1.0) < 1e-6, sigma) == (True, 1.0)
    # on the axis, between the centres: the side is nearest
    d, *normal, _ = round_cone_distance(F32(5), F32(0), F32(0), *a, F32(2), *b, F32(1))
    assert abs(d - (5 * sin - 2)) < 1e-5


@pytest.mark.parametrize("dtype", [np.float32, np.float64], ids=["f32", "f64"])
def test_capsule_distance_is_round_cone_distance_within_reach(dtype):
    """The record's axis terms (capsule_axis) match the reference; capsule_distance gives
    round_cone_distance's very bits within reach and +inf beyond it, where the distance is
    positive (the reference agrees on which points are beyond), on tapered, uniform and
    nested capsules."""
    rng = np.random.default_rng(7)
    rejected = kept = 0
    for case in range(60):
        C = np.zeros((1, CAPSULE_COLUMNS), dtype)
        a, ra, b, rb = random_capsule(rng)
        if case % 10 == 0:
            rb = ra  # uniform radius
        if case % 10 == 1:
            b, rb = a + F32(0.01), F32(ra * 0.5)  # b inside a
        C[0, 8:11], C[0, 11], C[0, 12:15], C[0, 15] = a, ra, b, rb
        capsule_axis(C, 0)
        want = C.astype(np.float64)
        ref.capsule_axis(want, 0)
        np.testing.assert_allclose(C[0, 17:24], want[0, 17:24], rtol=1e-5, atol=1e-6)
        for _ in range(40):
            p = (a + rng.uniform(-0.5, 1.5) * (b - a) + rng.normal(0, 0.3, 3)).astype(dtype)
            got = capsule_distance(*p, C, 0)
            full = round_cone_distance(*p, *C[0, 8:16])
            if np.isinf(got[0]):
                rejected += 1
                assert full[0] > 0.2 * max(ra, rb) * (1 - 1e-5), full
            else:
                kept += 1
                assert np.array(got, dtype).tobytes() == np.array(full, dtype).tobytes()
            reach, axis = 1.25 * max(ra, rb), (b - a).astype(np.float64)
            axial = (p - a) @ axis / np.linalg.norm(axis)
            radial = np.linalg.norm(p - a - axial * axis / np.linalg.norm(axis))
            edges = (radial - reach, axial + reach, axial - np.linalg.norm(axis) - reach)
            if min(abs(e) for e in edges) > 1e-4:  # away from the reach's boundary
                assert np.isinf(got[0]) == np.isinf(ref.capsule_distance(*p, C, 0)[0])
    assert rejected > 300 and kept > 300


def test_round_cone_degenerates_to_the_bigger_sphere():
    a, b = f32([0, 0, 0]), f32([0.1, 0, 0])
    p = f32([0.0, 1.0, 0.0])
    d, *_ = round_cone_distance(*p, *a, F32(0.5), *b, F32(0.3))  # b inside a
    assert abs(d - 0.5) < 1e-6
    assert abs(ref.round_cone_distance(*p, *a, 0.5, *b, 0.3)[0] - 0.5) < 1e-9


def test_convex_distance_matches_reference():
    rng = np.random.default_rng(5)
    planes = np.zeros((7, 4), np.float32)
    planes[:, :3] = unit(rng, 7)
    planes[:, 3] = rng.uniform(0.2, 0.5, 7)
    for _ in range(200):
        p = f32(rng.uniform(-0.6, 0.6, 3))
        got = convex_distance(*p, planes, 1, 7, F32(0.01))
        np.testing.assert_allclose(got, ref.convex_distance(*p, planes, 1, 7, 0.01), atol=2e-6)
    assert convex_distance(F32(0), F32(0), F32(0), planes, 3, 3, F32(0.0))[0] == np.inf


@pytest.mark.parametrize("seed", range(2))
def test_sphere_time_of_impact_matches_reference(seed):
    """Particles flying at moving, growing spheres: hits (also after passing through the
    centre), misses, starts inside."""
    rng = np.random.default_rng(seed)
    hits = 0
    for _ in range(60):
        c0 = rng.uniform(-0.2, 0.2, 3)
        c1 = c0 + rng.normal(0, 0.1, 3)
        r0, r1 = rng.uniform(0.05, 0.2, 2)
        q = rng.uniform(-0.6, 0.6, 3)
        p = c1 + rng.normal(0, 0.15, 3)
        args = (*f32(q), *f32(p), *f32(c0), F32(r0), *f32(c1), F32(r1))
        got = sphere_time_of_impact(*args)
        want = ref.sphere_time_of_impact(*np.asarray(args, np.float64))
        assert (got < 0) == (want < 0), (got, want)
        if want >= 0:
            hits += 1
            assert abs(got - want) < 2e-4, (got, want)
    assert hits > 8


def capsule_record(a0, ra0, b0, rb0, a1, ra1, b1, rb1, mu=0.5):
    return f32([[*a0, ra0, *b0, rb0, *a1, ra1, *b1, rb1, mu]])


def test_capsule_at_interpolates():
    data = capsule_record([0, 0, 0], 1, [1, 0, 0], 2, [0, 1, 0], 3, [1, 1, 0], 4)
    np.testing.assert_allclose(capsule_at(data, 0, F32(0.25)), ref.capsule_at(data, 0, 0.25), atol=1e-6)


@pytest.mark.parametrize("seed", range(2))
def test_capsule_time_of_impact_matches_reference(seed):
    """Moving, rotating, growing tapered capsules against moving points: the time, normal and
    sigma of the first contact (cases with a clear hit or a clear miss)."""
    rng = np.random.default_rng(10 + seed)
    hits = 0
    tried = 0
    while tried < 16:
        a0, b0 = rng.uniform(-0.3, 0.3, 3), rng.uniform(-0.3, 0.3, 3)
        shift = rng.normal(0, 0.1, 3)
        a1, b1 = a0 + shift + rng.normal(0, 0.02, 3), b0 + shift + rng.normal(0, 0.02, 3)
        ra0, rb0 = rng.uniform(0.03, 0.12, 2)
        ra1, rb1 = ra0 * rng.uniform(0.9, 1.1), rb0 * rng.uniform(0.9, 1.1)
        data = capsule_record(a0, ra0, b0, rb0, a1, ra1, b1, rb1)
        q = rng.uniform(-0.6, 0.6, 3)
        p = 0.5 * (a1 + b1) + rng.normal(0, 0.12, 3)
        q, p = f32(q), f32(p)
        # skip grazing paths: the reference's closest approach must be clearly in or out
        ts = np.linspace(0, 1, 51)
        gaps = [ref._union_gap(q + t * (p - q), ref.capsule_at(data, 0, t)) for t in ts]
        if min(gaps) > -0.01 and min(gaps) < 0.01:
            continue
        tried += 1
        got = capsule_time_of_impact(*q, *p, data, 0)
        want = ref.capsule_time_of_impact(*q, *p, data, 0)
        assert (got[0] < 0) == (want[0] < 0), (got, want)
        if want[0] >= 0:
            hits += 1
            # the kernel stops within 1e-4 of the radius before the surface
            assert abs(got[0] - want[0]) < 2e-3, (got, want)
            np.testing.assert_allclose(got[1:4], want[1:4], atol=2e-2)
            assert abs(got[4] - want[4]) < 2e-2
    assert hits >= 3


def test_rotate_between_matches_reference():
    rng = np.random.default_rng(4)
    for _ in range(50):
        u, w, v = f32(unit(rng)), f32(unit(rng)), f32(rng.normal(size=3))
        if u @ w < -0.99:
            continue
        np.testing.assert_allclose(rotate_between(*u, *w, *v), ref.rotate_between(*u, *w, *v), atol=2e-5)
    u = f32([1, 0, 0])
    assert rotate_between(*u, *f32([-1, 0, 0]), F32(1), F32(2), F32(3)) == (1.0, 2.0, 3.0)
