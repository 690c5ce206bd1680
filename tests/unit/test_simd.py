"""clothtool._simd: the float4 intrinsics against plain numpy on random rows."""

from __future__ import annotations

import numba
import numpy as np
import pytest

from clothtool._simd import fill, is_double, keep_w, lane, load4, store4, transpose4, vadd, vmul, vsub, w_lanes


@numba.njit
def _combine(flat, a, b, out, x):
    """out rows 0-4: pa + pb, pb - pa, pa * pb, (pa + pb * x with pa's w), fill(x)."""
    pa = load4(flat, 4 * a)
    pb = load4(flat, 4 * b)
    store4(out, 0, vadd(pa, pb))
    store4(out, 4, vsub(pb, pa))
    store4(out, 8, vmul(pa, pb))
    store4(out, 12, keep_w(vadd(pa, vmul(pb, fill(pb, x))), pa))
    store4(out, 16, fill(pa, x))
    return lane(pa, 0), lane(pa, 1), lane(pa, 2), lane(pa, 3)


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_intrinsics_match_numpy(seed, dtype):
    rng = np.random.default_rng(seed)
    rows = rng.normal(size=(7, 4)).astype(dtype)
    a, b = rng.choice(7, 2, replace=False)
    x = dtype(rng.normal())
    out = np.zeros(20, dtype)
    lanes = _combine(rows.reshape(-1), a, b, out, x)
    pa, pb = rows[a], rows[b]
    np.testing.assert_array_equal(out[0:4], pa + pb)
    np.testing.assert_array_equal(out[4:8], pb - pa)
    np.testing.assert_array_equal(out[8:12], pa * pb)
    exact = pa.astype(np.longdouble) + pb.astype(np.longdouble) * x
    eps = np.finfo(dtype).eps
    np.testing.assert_allclose(out[12:15], exact[:3].astype(np.float64), rtol=2 * eps, atol=2 * eps)  # one rounding or two
    assert out[15] == pa[3]  # keep_w: the inverse mass bit for bit
    np.testing.assert_array_equal(out[16:20], np.full(4, x))
    np.testing.assert_array_equal(np.array(lanes, dtype), pa)


def test_store_touches_only_its_row():
    rows = np.arange(12, dtype=np.float32)
    out = np.full(12, -1.0, np.float32)

    @numba.njit
    def copy_middle(src, dst):
        store4(dst, 4, load4(src, 4))

    copy_middle(rows, out)
    np.testing.assert_array_equal(out, [-1, -1, -1, -1, 4, 5, 6, 7, -1, -1, -1, -1])


def test_wrong_argument_types_do_not_compile():
    """A float64 vector cannot be stored into float32 rows."""
    @numba.njit
    def mixed(source, target):
        store4(target, 0, load4(source, 0))

    with pytest.raises(numba.core.errors.TypingError):
        mixed(np.zeros(4), np.zeros(4, np.float32))


@numba.njit
def _columns(flat, out):
    """out rows 0-3: the columns of the first four rows; row 4: their w lanes."""
    r0, r1, r2, r3 = load4(flat, 0), load4(flat, 4), load4(flat, 8), load4(flat, 12)
    x, y, z, w = transpose4(r0, r1, r2, r3)
    store4(out, 0, x)
    store4(out, 4, y)
    store4(out, 8, z)
    store4(out, 12, w)
    store4(out, 16, w_lanes(r0, r1, r2, r3))


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_transpose_and_w_lanes(dtype):
    rows = np.arange(16, dtype=dtype).reshape(4, 4) * dtype(1.5) - dtype(3)
    out = np.zeros(20, dtype)
    _columns(rows.reshape(-1), out)
    np.testing.assert_array_equal(out[:16].reshape(4, 4), rows.T)
    np.testing.assert_array_equal(out[16:], rows[:, 3])


@numba.njit
def _precision_of(array):
    return is_double(array)


@pytest.mark.parametrize("dtype,double", [(np.float32, False), (np.float64, True)])
def test_is_double_tells_the_precision(dtype, double):
    assert _precision_of(np.zeros(3, dtype)) is double
    assert _precision_of(np.zeros((2, 4), dtype)) is double
