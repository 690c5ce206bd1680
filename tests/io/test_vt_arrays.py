"""Vt arrays filled through numpy: the same values Vt's own FromNumpy gives, each array its
own storage, and FromNumpy where this pxr does not export an array's own storage."""

from __future__ import annotations

import numpy as np
import pytest
from pxr import Gf, Sdf, Vt

from clothtool.io import vt_arrays
from clothtool.io.vt_arrays import vec3f_array


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_same_values_as_vts_own_conversion(dtype):
    points = np.random.default_rng(5).normal(size=(1000, 3)).astype(dtype)
    ours = vec3f_array(points)
    assert isinstance(ours, Vt.Vec3fArray) and len(ours) == 1000
    assert ours == Vt.Vec3fArray.FromNumpy(points.astype(np.float32))
    assert ours[999] == Gf.Vec3f(*points[999].astype(np.float32).tolist())  # read through Vt, not a buffer


def test_arrays_do_not_share_storage_with_each_other_or_the_source():
    points = np.arange(12, dtype=np.float32).reshape(4, 3)
    first = vec3f_array(points)
    points[...] = -1.0  # the solver reuses its arrays
    second = vec3f_array(points)
    assert first[3] == Gf.Vec3f(9, 10, 11) and second[3] == Gf.Vec3f(-1, -1, -1)


def test_a_layer_keeps_each_frames_sample():
    layer = Sdf.Layer.CreateAnonymous("test.usda")
    prim = Sdf.CreatePrimInLayer(layer, "/Cloth")
    attr = Sdf.AttributeSpec(prim, "points", Sdf.ValueTypeNames.Point3fArray)
    points = np.zeros((3, 3), np.float32)
    for time in (1.0, 2.0):
        points[:, 0] = time
        layer.SetTimeSample(attr.path, time, vec3f_array(points))
    assert [layer.QueryTimeSample(attr.path, t)[0][0] for t in (1.0, 2.0)] == [1.0, 2.0]


def test_empty_and_misshapen_arrays():
    assert len(vec3f_array(np.zeros((0, 3), np.float32))) == 0
    with pytest.raises(ValueError, match=r"expected \(n,3\) points, got shape \(4, 2\)"):
        vec3f_array(np.zeros((4, 2), np.float32))


def test_falls_back_to_from_numpy_where_the_export_is_a_copy(monkeypatch):
    """A pxr whose buffer export is a detached copy: the probe sees the write lost."""
    monkeypatch.setattr(vt_arrays, "_fill", lambda array, points: None)  # the write reaches no array
    vt_arrays._exports_storage.cache_clear()
    try:
        assert not vt_arrays._exports_storage()
        points = np.random.default_rng(1).normal(size=(10, 3)).astype(np.float32)
        assert vec3f_array(points) == Vt.Vec3fArray.FromNumpy(points)
    finally:
        monkeypatch.undo()
        vt_arrays._exports_storage.cache_clear()
    assert vt_arrays._exports_storage()  # this pxr: the array's own storage
