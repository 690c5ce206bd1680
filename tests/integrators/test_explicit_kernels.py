"""The explicit integrator's numba kernels against their numpy references (tests/reference/explicit_*).

Kernels run in float32, references in float64 from the same (float32) inputs; each tolerance
is a few float32 roundings of the magnitudes involved.
"""

from __future__ import annotations

import numpy as np
import pytest

from clothtool.integrators.explicit.kernels.explicit_collide import collide_colliders
from clothtool.integrators.explicit.kernels.explicit_integrate import symplectic_euler
from clothtool.integrators.explicit.kernels.explicit_springs import spring_forces, spring_forces_sets
from clothtool.integrators.explicit.kernels.explicit_wind import wind_forces
from clothtool.mesh.shapes import grid
from tests.kernels._data import F32, U, assert_close, f32, particles
from tests.kernels.test_collide import moving_frame, scene, still_frame
from tests.reference import explicit_collide as ref_collide
from tests.reference import explicit_integrate as ref_integrate
from tests.reference import explicit_springs as ref_springs
from tests.reference import explicit_wind as ref_wind

H = F32(1.0 / 600.0)


def conflict_free_sets(rng, n, count, movable):
    """Random distinct pairs grouped into sets with no movable particle twice (greedy), as
    (indices (c,2) sorted by set, set_offsets)."""
    sets: list[list[tuple[int, int]]] = []
    used: list[set[int]] = []
    for _ in range(count):
        a, b = (int(v) for v in rng.choice(n, 2, replace=False))
        ends = {p for p in (a, b) if movable[p]}
        for members, taken in zip(sets, used):
            if not ends & taken:
                members.append((a, b))
                taken |= ends
                break
        else:
            sets.append([(a, b)])
            used.append(set(ends))
    indices = np.array([pair for members in sets for pair in members], np.int32).reshape(-1, 2)
    offsets = np.concatenate([[0], np.cumsum([len(m) for m in sets])]).astype(np.int32)
    return indices, offsets


def random_springs(rng, n=40, count=120):
    cur, _ = particles(rng, n, pinned=0.2)
    movable = cur[:, 3] > 0
    indices, offsets = conflict_free_sets(rng, n, count, movable)
    length = np.linalg.norm(cur[indices[:, 1], :3] - cur[indices[:, 0], :3], axis=1)
    rest = f32(length * rng.uniform(0.8, 1.2, length.shape))
    stiffness = f32(rng.uniform(10.0, 1000.0, length.shape))
    damping = f32(rng.uniform(0.0, 5.0, length.shape))
    velocity = f32(rng.normal(0.0, 1.0, (n, 3)))
    force = f32(rng.normal(0.0, 1.0, (n, 3)))
    return indices, rest, stiffness, damping, offsets, cur, velocity, force


@pytest.mark.parametrize("seed", range(4))
def test_spring_forces_match_reference_and_the_set_kernel(seed):
    indices, rest, stiffness, damping, offsets, cur, velocity, force = random_springs(np.random.default_rng(seed))
    springs = (indices, rest, stiffness, damping)
    serial = force.copy()
    spring_forces(*springs, cur, velocity, serial)
    by_sets = force.copy()
    spring_forces_sets(*springs, offsets, cur, velocity, by_sets)
    # each spring: k (l - L) with |x| <= 1.2 costs ~8 roundings of k * 2.4, the damping term
    # ~6 of c |r|; a particle sums at most `degree` springs
    degree = np.bincount(indices.reshape(-1), minlength=cur.shape[0]).max()
    atol = 16 * U * degree * float((stiffness * 4.0 + damping * 6.0).max()) + 4 * U * np.abs(force).max()
    want = ref_springs.spring_forces(*springs, cur, velocity, force)
    assert_close(serial, want, atol, "force")
    assert_close(by_sets, ref_springs.spring_forces_sets(*springs, offsets, cur, velocity, force), atol, "force (sets)")
    movable = cur[:, 3] > 0
    np.testing.assert_array_equal(serial[movable], by_sets[movable])  # same order of additions: same bits
    np.testing.assert_array_equal(by_sets[~movable], force[~movable])  # the set kernel skips pinned slots
    assert np.abs(want - force).max() > 1000 * atol  # real forces were exercised


def test_spring_forces_restore_and_damp():
    """One spring along x, a pinned at 0, b at 1.5 with rest 1: b is pulled back (-x) by
    k * 0.5; moving apart at 2 m/s adds c * 2 against the motion."""
    cur = f32([[0, 0, 0, 0], [1.5, 0, 0, 1]])
    velocity = f32([[0, 0, 0], [2, 0, 0]])
    force = np.zeros((2, 3), np.float32)
    spring = (np.array([[0, 1]], np.int32), f32([1.0]), f32([100.0]), f32([3.0]))
    spring_forces_sets(*spring, np.array([0, 1], np.int32), cur, velocity, force)
    np.testing.assert_allclose(force, [[0, 0, 0], [-(100 * 0.5 + 3 * 2), 0, 0]], rtol=1e-6)


def test_zero_length_spring_exerts_nothing():
    cur = f32([[0.5, 0.5, 0.5, 1], [0.5, 0.5, 0.5, 1]])
    force = np.zeros((2, 3), np.float32)
    spring_forces(np.array([[0, 1]], np.int32), f32([1.0]), f32([100.0]), f32([3.0]), cur, f32(np.ones((2, 3))), force)
    assert not force.any()


@pytest.mark.parametrize("seed", range(4))
def test_wind_forces_match_reference(seed):
    rng = np.random.default_rng(10 + seed)
    mesh = grid(7, 6, spacing=0.2)
    triangles = np.ascontiguousarray(mesh.face_vertex_indices.reshape(-1, 3), np.int32)
    n = mesh.vertex_count
    cur = np.empty((n, 4), np.float32)
    cur[:, :3] = mesh.vertex_pos + rng.normal(0.0, 0.05, (n, 3))
    cur[:, 3] = np.where(rng.random(n) < 0.15, 0.0, rng.uniform(0.5, 2.0, n))
    velocity = f32(rng.normal(0.0, 2.0, (n, 3)))
    air = f32(rng.normal(0.0, 5.0, 3))
    drag, lift, density = F32(rng.uniform(0.1, 1.0)), F32(rng.uniform(0.1, 1.0)), F32(rng.uniform(0.05, 0.2))
    force = f32(rng.normal(0.0, 0.01, (n, 3)))
    share = f32(rng.uniform(0.75, 1.5, n))
    got = force.copy()
    wind_forces(triangles, share, air, drag, lift, density, cur, velocity, got)
    want = ref_wind.wind_forces(triangles, share, air, drag, lift, density, cur, velocity, force)
    # ~20 roundings per triangle's force, <= 6 triangles a corner: relative to the largest sum
    atol = 6 * 32 * U * np.abs(want - force).max()
    assert_close(got, want, atol, "force")
    assert np.abs(want - force).max() > 1000 * atol


def test_wind_on_a_degenerate_triangle_is_zero():
    cur = f32([[0, 0, 0, 1], [1, 0, 0, 1], [2, 0, 0, 1]])
    force = np.zeros((3, 3), np.float32)
    wind_forces(np.array([[0, 1, 2]], np.int32), f32([1, 1, 1]), f32([0, 0, 5]), F32(1.0), F32(1.0), F32(1.0), cur, f32(np.zeros((3, 3))), force)
    assert not force.any()


@pytest.mark.parametrize("seed", range(4))
def test_symplectic_euler_matches_reference(seed):
    rng = np.random.default_rng(20 + seed)
    cur, prev = particles(rng, 50, pinned=0.3)
    velocity = f32(rng.normal(0.0, 1.0, (50, 3)))
    velocity[cur[:, 3] == 0] = 0.0
    force = f32(rng.normal(0.0, 10.0, (50, 3)))
    gravity = f32([0.0, -9.81, 0.0])
    want = ref_integrate.symplectic_euler(gravity, H, force, cur, prev, velocity)
    got = [a.copy() for a in (cur, prev, velocity)]
    symplectic_euler(gravity, H, force, *got)
    # v: |v| + h (|g| + 2 |f|) ~ 5, three roundings; x: |x| <= 1.1 plus h v, two roundings
    assert_close(got[2], want[2], 8 * U * 5.0, "velocity")
    assert_close(got[0], want[0], 8 * U * 1.2, "cur")
    np.testing.assert_array_equal(got[1][:, :3][cur[:, 3] > 0], cur[cur[:, 3] > 0, :3])  # prev = old x exactly
    pinned = cur[:, 3] == 0
    for before, after in zip((cur, prev, velocity), got):
        np.testing.assert_array_equal(after[pinned], before[pinned])


# ---------------------------------------------------------------------------- collisions
def contact_particles(rng, n, speed=0.03):
    """Particles around the shared collide tests' scene (tests/kernels/test_collide.py):
    prev the substep's start, cur its end, some pinned (w = 0 in cur)."""
    prev = np.empty((n, 4), np.float32)
    prev[:, :3] = rng.uniform(-0.6, 0.6, (n, 3))
    prev[:, 3] = 1.0
    cur = prev.copy()
    cur[:, :3] += rng.normal(0, speed, (n, 3))
    cur[rng.random(n) < 0.1, 3] = 0.0
    velocity = f32((cur[:, :3] - prev[:, :3]) / H + rng.normal(0.0, 0.5, (n, 3)))
    return cur, prev, velocity


@pytest.mark.parametrize("frame", [still_frame(), moving_frame()], ids=["still", "moving"])
@pytest.mark.parametrize("speed", [0.03, 0.3])
def test_collide_colliders_matches_reference(frame, speed):
    """Spheres, a tapered capsule, convexes and a mesh moving over the substep; at 0.3 per
    substep the paths cross colliders whole (continuous collision)."""
    rng = np.random.default_rng(30)
    shapes, mesh = scene(rng, frame)
    cur, prev, velocity = contact_particles(rng, 200, speed)
    got = [a.copy() for a in (cur, prev, velocity)]
    collide_colliders(shapes, mesh, frame, H, *got)
    want = ref_collide.collide_colliders(shapes, mesh, frame, H, cur, prev, velocity)
    for name, g, w in zip(("cur", "prev", "velocity"), got, want):
        scale = 1.0 if name != "velocity" else 1.0 / H
        assert_close(g, w, 2e-4 * scale, name)
    pinned = cur[:, 3] == 0
    for before, after in zip((cur, prev, velocity), got):
        np.testing.assert_array_equal(after[pinned], before[pinned])
    moved = np.abs(want[0][:, :3] - cur[:, :3].astype(np.float64)).max(axis=1) > 1e-6
    assert moved.sum() >= 20  # contacts were exercised


def test_contact_response_inelastic_with_coulomb_friction():
    """A particle 1 cm inside a ground plane (y = 0, margin 0), falling at 1 m/s and sliding at
    3 m/s, mu = 0.5: it ends on the plane, its normal velocity is gone and its tangential
    speed drops by mu * 1 = 0.5 m/s; sliding at 0.3 m/s instead it sticks."""
    e = np.zeros((0, 9), np.float32), np.zeros((0, 24), np.float32)
    shapes = (*e, f32([[0.0, 1.0, 0.0, 0.0]]), np.array([0, 1], np.int32), f32([[0.0, 0.5, 0.0, 0.0, 0.0]]))
    _, mesh = scene(np.random.default_rng(0), still_frame())
    mesh = (mesh[0][:0], *mesh[1:])
    for slide, expected in ((3.0, 2.5), (0.3, 0.0)):
        cur = f32([[0.2, -0.01, 0.0, 1.0]])
        prev = f32([[0.2, 0.0, 0.0, 1.0]])
        velocity = f32([[slide, -1.0, 0.0]])
        collide_colliders(shapes, mesh, still_frame(), H, cur, prev, velocity)
        np.testing.assert_allclose(cur[0, :3], [0.2, 0.0, 0.0], atol=1e-7)
        np.testing.assert_allclose(velocity[0], [expected, 0.0, 0.0], atol=1e-6)
        np.testing.assert_allclose(prev[0, :3], cur[0, :3] - H * velocity[0], atol=1e-7)
