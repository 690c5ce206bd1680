"""vec3f_array: numpy points into a Vt.Vec3fArray, bit for bit what FromNumpy gives."""

from __future__ import annotations

import numpy as np
import pytest

from clothtool.io import vt_points
from clothtool.io.vt_points import Vt, vec3f_array


def as_numpy(array) -> np.ndarray:
    return np.array([tuple(array[i]) for i in range(len(array))], np.float32).reshape(-1, 3)


@pytest.mark.parametrize("fills_in_place", [True, False], ids=["memcpy", "FromNumpy"])
@pytest.mark.parametrize("n", [0, 1, 1000])
def test_the_points_arrive_bit_for_bit(monkeypatch, fills_in_place, n):
    """Either way (this USD build copies in place; the FromNumpy fallback), the same bits
    as FromNumpy, NaN payloads and signed zeros included."""
    monkeypatch.setattr(vt_points, "_fills_in_place", lambda: fills_in_place)
    points = np.random.default_rng(n).normal(size=(n, 3)).astype(np.float32)
    if n:
        points.view(np.uint32)[0] = [0x7FC00001, 0x80000000, 0xFF800000]  # NaN with payload, -0.0, -inf
    array = vec3f_array(points)
    assert isinstance(array, Vt.Vec3fArray) and len(array) == n
    ours, theirs = as_numpy(array), as_numpy(Vt.Vec3fArray.FromNumpy(points))
    np.testing.assert_array_equal(ours.view(np.uint32), points.view(np.uint32))
    np.testing.assert_array_equal(theirs.view(np.uint32), points.view(np.uint32))


def test_this_usd_build_fills_in_place():
    """The fast path is the one taken here (the probe reads its array back through Vt)."""
    assert vt_points._fills_in_place()


def test_each_call_gives_a_new_array_the_input_cannot_change():
    points = np.ones((4, 3), np.float32)
    first = vec3f_array(points)
    points[...] = 2.0
    second = vec3f_array(points)
    np.testing.assert_array_equal(as_numpy(first), np.ones((4, 3)))
    np.testing.assert_array_equal(as_numpy(second), np.full((4, 3), 2.0))


def test_wider_or_strided_input_is_rounded_as_from_numpy_rounds_it():
    points = np.random.default_rng(5).normal(size=(50, 4))[:, :3]  # float64, not contiguous
    np.testing.assert_array_equal(as_numpy(vec3f_array(points)), as_numpy(Vt.Vec3fArray.FromNumpy(np.ascontiguousarray(points))))


def test_other_shapes_are_refused():
    with pytest.raises(ValueError, match=r"points must have shape \(n, 3\), got \(4, 2\)"):
        vec3f_array(np.zeros((4, 2), np.float32))
