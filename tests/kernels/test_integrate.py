"""integrate_linear / integrate_affine / mean_displacement / integrate_free against tests/reference/integrate.py."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from clothtool.solver.kernels.integrate import _row, integrate_affine, integrate_free, integrate_linear, mean_displacement
from tests.kernels._data import F32, U, assert_close, f32, particles
from tests.reference import integrate as ref

# |x| <= ~1.1 and |x - x_prev| * scale + |bias| << 1: each coordinate is three roundings of
# values below 2, so the kernel is within 3 * U * 2 ~ 4e-7 of the exact result.
ATOL_LINEAR = 8 * U * 2
# the affine form adds six products of |M| <= ~1.1 by |x| <= ~1.1 and a sum of five terms
# of magnitude <= ~2.5: about 12 roundings of values below 3.
ATOL_AFFINE = 16 * U * 3


def disturb_cur_w(rng, cur):
    """Inverse masses as the last iteration left them: some zeroed by motion constraints,
    some scaled by collision (the kernel restores them from prev.w)."""
    n = cur.shape[0]
    pick = rng.random(n)
    cur[pick < 0.2, 3] = 0.0
    cur[(pick >= 0.2) & (pick < 0.4), 3] *= F32(0.25)


def run(kernel, *args, cur, prev):
    cur, prev = cur.copy(), prev.copy()
    kernel(*args, cur, prev)
    return cur, prev


def check(cur0, prev0, cur, prev, ref_cur, ref_prev, atol):
    assert_close(cur, ref_cur, atol, "cur")
    # prev takes a copy of cur's xyz and keeps its w: exactly, not just closely
    np.testing.assert_array_equal(prev, ref_prev)
    np.testing.assert_array_equal(prev[:, :3], cur0[:, :3])
    np.testing.assert_array_equal(prev[:, 3], prev0[:, 3])
    np.testing.assert_array_equal(cur[:, 3], ref_cur[:, 3])
    pinned = prev0[:, 3] == 0
    np.testing.assert_array_equal(cur[pinned], cur0[pinned])  # pinned particles do not move


@settings(max_examples=25)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(0, 70), pinned=st.sampled_from([0.0, 0.3, 1.0]))
def test_integrate_linear_matches_reference(seed, n, pinned):
    rng = np.random.default_rng(seed)
    cur0, prev0 = particles(rng, n, pinned=pinned)
    disturb_cur_w(rng, cur0)
    scale = F32(rng.uniform(0.5, 1.2))  # damping times the time-step ratio
    bias = f32(rng.normal(0.0, 1e-3, 3))  # gravity * dt^2
    cur, prev = run(integrate_linear, scale, bias, cur=cur0, prev=prev0)
    ref_cur, ref_prev = ref.integrate_linear(scale, bias, cur0, prev0)
    check(cur0, prev0, cur, prev, ref_cur, ref_prev, ATOL_LINEAR)


def random_frame_matrices(rng, scale):
    """(m_cur, m_prev) as solver.frame builds them: s Q + K and -s Q, Q near a rotation."""
    angle = rng.normal(0.0, 0.05, 3)
    x, y, z = angle
    q = np.eye(3) + np.array([[0, -z, y], [z, 0, -x], [-y, x, 0]])
    k = rng.normal(0.0, 0.01, (3, 3))
    return f32(scale * q + k), f32(-scale * q)


@settings(max_examples=25)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(0, 70))
def test_integrate_affine_matches_reference(seed, n):
    rng = np.random.default_rng(seed)
    cur0, prev0 = particles(rng, n, pinned=0.25)
    disturb_cur_w(rng, cur0)
    m_cur, m_prev = random_frame_matrices(rng, rng.uniform(0.5, 1.0))
    bias = f32(rng.normal(0.0, 1e-3, 3))
    cur, prev = run(integrate_affine, m_cur, m_prev, bias, cur=cur0, prev=prev0)
    ref_cur, ref_prev = ref.integrate_affine(m_cur, m_prev, bias, cur0, prev0)
    check(cur0, prev0, cur, prev, ref_cur, ref_prev, ATOL_AFFINE)


def test_affine_with_identity_frame_is_linear():
    """M_cur = s I, M_prev = -s I is plain Verlet: both kernels agree with the linear reference."""
    rng = np.random.default_rng(7)
    cur0, prev0 = particles(rng, 40)
    s = F32(0.98)
    bias = f32([0.0, -2.7e-4, 0.0])
    eye = np.eye(3, dtype=np.float32)
    cur, _ = run(integrate_affine, s * eye, -s * eye, bias, cur=cur0, prev=prev0)
    ref_cur, _ = ref.integrate_linear(s, bias, cur0, prev0)
    assert_close(cur, ref_cur, ATOL_AFFINE, "cur")


@pytest.mark.parametrize("r", [0, 1, 2])
def test_row_matches_reference(r):
    rng = np.random.default_rng(r)
    m = f32(rng.normal(size=(3, 3)))
    x, y, z = (F32(v) for v in rng.normal(size=3))
    # three products and two sums of values below ~4
    assert abs(_row(m, r, x, y, z) - ref._row(m, r, x, y, z)) <= 8 * U * 4


def test_empty_arrays():
    empty = np.zeros((0, 4), np.float32)
    cur, prev = run(integrate_linear, F32(1.0), f32(np.zeros(3)), cur=empty, prev=empty)
    assert cur.shape == prev.shape == (0, 4)
    eye = np.eye(3, dtype=np.float32)
    cur, prev = run(integrate_affine, eye, eye, f32(np.zeros(3)), cur=empty, prev=empty)
    assert cur.shape == prev.shape == (0, 4)


def test_integrate_linear_in_float64_state():
    rng = np.random.default_rng(3)
    cur0, prev0 = particles(rng, 50, pinned=0.3)
    cur0, prev0 = cur0.astype(np.float64), prev0.astype(np.float64)
    bias = np.array([0.0, -9.81 / 300**2, 0.0])
    cur, prev = run(integrate_linear, 0.99, bias, cur=cur0, prev=prev0)
    ref_cur, ref_prev = ref.integrate_linear(0.99, bias, cur0, prev0)
    assert cur.dtype == np.float64
    check(cur0, prev0, cur, prev, ref_cur, ref_prev, 1e-15)


@settings(max_examples=25)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(0, 70), pinned=st.sampled_from([0.0, 0.3, 1.0]))
def test_mean_displacement_matches_reference(seed, n, pinned):
    """Summed in float64: each term is the exact float32 difference (cur and prev are within a
    factor 2 of each other or their difference is exact) times 1 / w, so only float64
    rounding separates kernel and reference."""
    rng = np.random.default_rng(seed)
    cur0, prev0 = particles(rng, n, pinned=pinned)
    disturb_cur_w(rng, cur0)  # cur.w plays no part: the masses are prev.w's
    out = np.full(3, np.nan)
    mean_displacement(cur0, prev0, out)
    np.testing.assert_allclose(out, ref.mean_displacement(cur0, prev0), rtol=1e-12, atol=1e-15)
    if not (prev0[:, 3] > 0).any():
        np.testing.assert_array_equal(out, np.zeros(3))


@settings(max_examples=25)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(0, 70), spared=st.sampled_from([0.0, 0.01, 0.2]))
def test_integrate_free_matches_reference(seed, n, spared):
    """A free cloth's step (every particle movable): the bias carries the spared share of the
    mean displacement; the bias is rounded to float32 once more than integrate_linear's."""
    rng = np.random.default_rng(seed)
    cur0, prev0 = particles(rng, n, pinned=0.0)
    disturb_cur_w(rng, cur0)
    scale = F32(rng.uniform(0.5, 1.2))
    bias = f32(rng.normal(0.0, 1e-3, 3))
    mean = np.full(3, np.nan)
    cur, prev = run(integrate_free, scale, spared, bias, mean, cur=cur0, prev=prev0)
    ref_cur, ref_prev = ref.integrate_free(scale, spared, bias, cur0, prev0)
    check(cur0, prev0, cur, prev, ref_cur, ref_prev, ATOL_LINEAR + U)
    if spared != 0.0 and n:
        np.testing.assert_allclose(mean, ref.mean_displacement(cur0, prev0), rtol=1e-12, atol=1e-15)
