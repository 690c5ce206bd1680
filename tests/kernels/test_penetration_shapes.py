"""round_cone_depths (the face penetration measure for spheres and capsules) against
tests/reference/penetration_shapes.py, a search over each face: random faces around tapered
and straight capsules, spheres and capsules one of whose end spheres holds the other,
inside and outside (the clearance), and faces near no cone (-inf)."""

from __future__ import annotations

import numpy as np
import pytest

from clothtool.solver.kernels.collide_shapes import CAPSULE_COLUMNS
from clothtool.solver.kernels.penetration_shapes import round_cone_depths
from tests.reference import penetration_shapes as ref


def random_cones(rng, count):
    cones = np.zeros((count, CAPSULE_COLUMNS))
    for q in range(count):
        a = rng.uniform(-0.2, 0.2, 3)
        kind = rng.integers(0, 4)
        if kind == 0:  # a sphere
            b, ra, rb = a, rng.uniform(0.03, 0.1), None
            rb = ra
        elif kind == 1:  # one end sphere holds the other
            ra = rng.uniform(0.06, 0.1)
            b, rb = a + rng.normal(0.0, 0.01, 3), ra * 0.3
        else:  # a tapered or straight capsule
            b = a + rng.normal(0.0, 0.15, 3)
            ra = rng.uniform(0.03, 0.1)
            rb = ra if kind == 2 else rng.uniform(0.02, 0.1)
        cones[q, 8:11], cones[q, 11], cones[q, 12:15], cones[q, 15] = a, ra, b, rb
    return cones


@pytest.mark.parametrize("seed", range(6))
def test_depths_match_the_search(seed):
    rng = np.random.default_rng(seed)
    faces = 60
    centres = rng.uniform(-0.3, 0.3, (faces, 1, 3))
    points = (centres + rng.normal(0.0, 0.04, (faces, 3, 3))).reshape(-1, 3)
    triangles = np.arange(3 * faces, dtype=np.int32).reshape(-1, 3)
    cones = random_cones(rng, 3)
    got = np.full(faces, -np.inf)
    round_cone_depths(points, triangles, cones.copy(), got)
    want = ref.round_cone_depths(points, triangles, cones, np.full(faces, -np.inf))
    np.testing.assert_array_equal(np.isinf(got), np.isinf(want))
    finite = np.isfinite(want)
    assert finite.sum() > 5 and (want[finite] > 0).any() and (want[finite] < 0).any()  # inside and clearances
    # the search finds the minimum to about a micrometre; the kernel is exact, so never shallower
    np.testing.assert_allclose(got[finite], want[finite], atol=2e-6)
    assert np.all(got[finite] >= want[finite] - 1e-12)


def test_a_face_keeps_a_deeper_depth_and_far_faces_stay():
    points = np.array([[0, 0, 0], [1, 0, 0], [0, 0, 1], [5, 5, 5], [6, 5, 5], [5, 5, 6]], np.float64)
    triangles = np.array([[0, 1, 2], [3, 4, 5]], np.int32)
    cones = np.zeros((1, CAPSULE_COLUMNS))
    cones[0, 8:11] = cones[0, 12:15] = [0.2, 0.05, 0.2]
    cones[0, 11] = cones[0, 15] = 0.1  # a sphere 5 cm above the first face, radius 10 cm
    depth = np.array([0.5, -np.inf])
    round_cone_depths(points, triangles, cones, depth)
    assert depth.tolist() == [0.5, -np.inf]  # deeper already; the second face is near nothing
    depth = np.full(2, -np.inf)
    round_cone_depths(points, triangles, cones, depth)
    assert depth[0] == pytest.approx(0.05, abs=1e-12) and depth[1] == -np.inf
