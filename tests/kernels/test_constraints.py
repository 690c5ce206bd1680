"""constrain_motion / constrain_separation / constrain_tethers against
tests/reference/constraints.py."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from clothtool.solver.kernels.constraints import constrain_motion, constrain_separation, constrain_tethers
from tests.kernels._data import F32, U, assert_close, f32, particles
from tests.reference import constraints as ref

# Positions below ~1.5 and corrections below ~1: a correction is ~8 float32 roundings of
# values below ~1.5 (the slack's 1 - r/l loses nothing relative to the move d * slack).
ATOL = 16 * U * 1.5

seeds = st.integers(0, 2**32 - 1)


def run(kernel, *args, cur):
    out = cur.copy()
    kernel(*args, out)
    return out


def sphere_radii(rng, n):
    """Motion radii: ordinary ones, and the edge cases 0, negative and inf (no constraint)."""
    radii = rng.uniform(0.01, 0.3, n)
    kind = rng.random(n)
    radii[kind < 0.1] = 0.0
    radii[(kind >= 0.1) & (kind < 0.2)] = -rng.uniform(0.01, 1.0, n)[(kind >= 0.1) & (kind < 0.2)]
    radii[(kind >= 0.2) & (kind < 0.3)] = np.inf
    return f32(radii)


@settings(max_examples=30)
@given(seed=seeds, n=st.integers(0, 60), unit=st.booleans())
def test_motion_matches_reference(seed, n, unit):
    rng = np.random.default_rng(seed)
    cur, _ = particles(rng, n, pinned=0.2)
    centers = f32(cur[:, :3] + rng.normal(0.0, 0.15, (n, 3)))
    coincide = rng.random(n) < 0.1
    centers[coincide] = cur[coincide, :3]  # particle exactly at its sphere's centre
    radii = sphere_radii(rng, n)
    # |bias| < 0.005 <= 0.01 * min(scale): a positive radius stays positive, so float32 and
    # float64 agree on which particles a radius <= 0 pins
    scale, bias = (F32(1), F32(0)) if unit else (F32(rng.uniform(0.5, 2.0)), F32(rng.uniform(-0.004, 0.004)))
    stiffness = F32(rng.uniform(0.05, 1.0))
    got = run(constrain_motion, centers, radii, scale, bias, stiffness, cur=cur)
    want = ref.constrain_motion(centers, radii, scale, bias, stiffness, cur)
    assert_close(got[:, :3], want[:, :3], ATOL, "xyz")
    np.testing.assert_array_equal(got[:, 3], want[:, 3])


def test_motion_radius_zero_or_less_pins():
    """radius <= 0 zeroes cur.w (the particle is pinned for this iteration) and pulls it to the
    centre by the stiffness; a particle at the centre stays put but is pinned too."""
    cur = f32([[1, 0, 0, 1], [0, 2, 0, 0.5], [3, 3, 3, 2], [0, 0, 0.05, 1], [5, 5, 5, 1]])
    centers = f32([[0, 0, 0], [0, 0, 0], [3, 3, 3], [0, 0, 0], [0, 0, 0]])
    radii = f32([0.0, -1.0, 0.0, 0.1, np.inf])
    got = run(constrain_motion, centers, radii, F32(1), F32(0), F32(0.5), cur=cur)
    want = ref.constrain_motion(centers, radii, F32(1), F32(0), F32(0.5), cur)
    np.testing.assert_array_equal(got[:, 3], [0, 0, 0, 1, 1])
    np.testing.assert_array_equal(want[:, 3], [0, 0, 0, 1, 1])
    assert_close(got, want, ATOL, "cur")
    assert_close(got[:2, :3], [[0.5, 0, 0], [0, 1, 0]], ATOL, "halfway to the centre")
    np.testing.assert_array_equal(got[2:, :3], cur[2:, :3])  # at its centre / inside / unconstrained


@settings(max_examples=30)
@given(seed=seeds, n=st.integers(0, 60))
def test_separation_matches_reference(seed, n):
    rng = np.random.default_rng(seed)
    cur, _ = particles(rng, n, pinned=0.0)
    offset = rng.normal(0.0, 1.0, (n, 3))
    offset *= (rng.uniform(0.01, 0.6, n) / np.linalg.norm(offset, axis=1))[:, None]
    centers = f32(cur[:, :3] + offset)
    radii = f32(rng.uniform(0.0, 0.4, n))
    radii[rng.random(n) < 0.1] = 0.0
    coincide = rng.random(n) < 0.1
    centers[coincide] = cur[coincide, :3]
    got = run(constrain_separation, centers, radii, cur=cur)
    want = ref.constrain_separation(centers, radii, cur)
    assert_close(got, want, ATOL, "cur")
    np.testing.assert_array_equal(got[coincide], cur[coincide])  # no direction to leave by
    # everyone ends on or outside their sphere
    outside = np.linalg.norm(got[:, :3].astype(np.float64) - centers, axis=1)
    assert np.all(coincide | (outside >= radii - ATOL))


def tether_setup(rng, n, k, inactive=0.2):
    """Pinned anchors above (y in [1, 1.5]) the free particles (y in [-1, 0.5]), so every
    active tether is longer than 0.5; pinned particles and inactive slots hold themselves
    with length 0 (the cook's layout)."""
    pinned = np.zeros(n, bool)
    pinned[rng.choice(n, max(1, n // 5), replace=False)] = True
    cur = np.empty((n, 4), np.float32)
    cur[:, :3] = rng.uniform(-1.0, 1.0, (n, 3))
    cur[pinned, 1] = rng.uniform(1.0, 1.5, pinned.sum())
    cur[~pinned, 1] = rng.uniform(-1.0, 0.5, (~pinned).sum())
    cur[:, 3] = np.where(pinned, 0.0, 1.0)
    pinned_ids = np.flatnonzero(pinned)
    anchors = np.tile(np.arange(n), k)
    lengths = np.zeros(k * n)
    for s in range(k):
        for i in np.flatnonzero(~pinned):
            if rng.random() < inactive:
                continue
            a = rng.choice(pinned_ids)
            anchors[s * n + i] = a
            # slack (length * scale > distance) and taut ones
            lengths[s * n + i] = np.linalg.norm(cur[a, :3] - cur[i, :3]) * rng.uniform(0.6, 1.3)
    return anchors.astype(np.int32), f32(lengths), cur, pinned


@settings(max_examples=25)
@given(seed=seeds, n=st.integers(1, 50), k=st.integers(1, 3))
def test_tethers_match_reference(seed, n, k):
    rng = np.random.default_rng(seed)
    anchors, lengths, cur, pinned = tether_setup(rng, n, k)
    scale = F32(rng.uniform(0.8, 1.2))
    stiffness = F32(rng.uniform(0.1, 1.0) * n / (k * n))  # NvCloth: k * numParticles / numTethers
    got = run(constrain_tethers, anchors, lengths, scale, stiffness, cur=cur)
    want = ref.constrain_tethers(anchors, lengths, scale, stiffness, cur)
    assert_close(got, want, ATOL, "cur")
    np.testing.assert_array_equal(got[pinned], cur[pinned])  # anchors never move


def test_tether_edge_cases():
    """k = 2 slots for 5 particles (pinned 0 and 4): particle 1 sits on its anchor (no
    direction), 2 hangs on a slack tether, 3 on two taut ones whose pulls add up; every other
    slot is a self slot of length 0."""
    cur = f32([[0, 2, 0, 0], [0, 2, 0, 1], [0, 1.5, 0, 1], [3, 0, 0, 1], [0, 0, 0, 0]])
    anchors = np.array([0, 0, 0, 0, 4, 0, 1, 2, 4, 4], np.int32)
    lengths = f32([0, 1, 1, 1, 0, 0, 0, 0, 2, 0])
    got = run(constrain_tethers, anchors, lengths, F32(1), F32(0.5), cur=cur)
    want = ref.constrain_tethers(anchors, lengths, F32(1), F32(0.5), cur)
    assert_close(got, want, ATOL, "cur")
    np.testing.assert_array_equal(got[[0, 1, 2, 4]], cur[[0, 1, 2, 4]])
    assert got[3, 0] < cur[3, 0]  # pulled back towards both anchors


def test_empty_arrays():
    empty = np.zeros((0, 4), np.float32)
    none = np.zeros(0, np.float32)
    assert run(constrain_motion, np.zeros((0, 3), np.float32), none, F32(1), F32(0), F32(1), cur=empty).shape == (0, 4)
    assert run(constrain_separation, np.zeros((0, 3), np.float32), none, cur=empty).shape == (0, 4)
    assert run(constrain_tethers, np.zeros(0, np.int32), none, F32(1), F32(1), cur=empty).shape == (0, 4)


def test_tethers_in_float64_state():
    """The precision option's float64 state runs the same kernel on <4 x double> rows."""
    rng = np.random.default_rng(7)
    anchors, lengths, cur, pinned = tether_setup(rng, 300, 2)  # more than one block of particles
    cur64 = cur.astype(np.float64)
    got = run(constrain_tethers, anchors, lengths, np.float64(1.0), np.float64(0.4), cur=cur64)
    want = ref.constrain_tethers(anchors, lengths, 1.0, 0.4, cur64)
    assert got.dtype == np.float64
    assert_close(got, want, 1e-12, "cur")
    assert np.abs(got - cur64).max() > 1e-3  # tethers pulled
