"""The geodesic propagation kernel against its plain-Python reference."""

from __future__ import annotations

import numpy as np
import pytest

from clothtool.cook import geodesic
from clothtool.cook.geodesic import geodesic_from_sources
from tests.reference import geodesic as reference
from tests.unit.test_geodesic import cylinder, jittered_sheet, l_shape


def _arguments(pos, triangles, sources, max_updates):
    n = pos.shape[0]
    order = np.argsort(triangles.reshape(-1), kind="stable")
    offsets = np.zeros(n + 1, np.int64)
    np.cumsum(np.bincount(triangles.reshape(-1), minlength=n), out=offsets[1:])
    can_bend = geodesic.bend_vertices(pos, triangles)
    can_bend[sources] = True
    return (pos, triangles, offsets, (order // 3).astype(np.int64), sources, can_bend, geodesic.LABELS_PER_VERTEX, max_updates)


@pytest.mark.parametrize(
    "mesh, sources",
    [
        (jittered_sheet(9, seed=3), [0]),
        (jittered_sheet(8, seed=4), [5, 6, 7]),
        (l_shape(11), [10]),
        (l_shape(11), [65]),
        (cylinder(12, 6), [3]),
    ],
    ids=["jittered-corner", "jittered-edge", "l-far-corner", "l-around-the-corner", "cylinder"],
)
def test_kernel_matches_reference(mesh, sources):
    pos, triangles = mesh
    args = _arguments(pos, triangles, np.asarray(sources, np.int64), 10**9)
    dist, root, done = geodesic_from_sources(*args)
    expected_dist, expected_root, expected_done = reference.geodesic_from_sources(*args)
    assert done and expected_done
    np.testing.assert_allclose(dist, expected_dist, rtol=1e-12, atol=0)
    np.testing.assert_array_equal(root, expected_root)


def test_kernel_and_reference_stop_at_the_budget():
    # which labels are out at the stop can differ (fused multiply-adds in the kernel reorder
    # near-ties in the heap), so only the verdict is compared
    pos, triangles = jittered_sheet(6, seed=5)
    args = _arguments(pos, triangles, np.array([0], np.int64), 10)
    assert not geodesic_from_sources(*args)[2]
    assert not reference.geodesic_from_sources(*args)[2]
