"""Spring forces with damping along the spring (the talk's "Spring Forces" and "Damping
Forces"), accumulated into a force array.

For each spring (a, b) with rest length L, stiffness k and damper c:

    d = x_b - x_a,  l = |d|,  u = d / l
    f = k (l - L) + c (v_b - v_a) . u
    force_a += f u ;  force_b -= f u

A stretched spring (l > L) or a separating one ((v_b - v_a) . u > 0) pulls a towards b and b
towards a. (The talk's transcript adds k (l - L) (x_a - x_b) / l to a, which would push a
stretched spring further apart; its pseudo-code is taken for its structure, with the restoring
sign.) A spring of zero length has no direction and exerts no force.

``spring_forces`` runs through the springs in order and also writes pinned particles' slots
(the integrator never reads them). ``spring_forces_sets`` runs each conflict-free set on all
cores and writes movable particles only (a set holds no movable particle twice, so no slot is
written by two threads); springs are stored set after set, so every movable particle receives
its forces in the same order, and the same bits, from both kernels.
"""

from __future__ import annotations

import numba
import numpy as np

from clothtool._jit import kernel


@kernel(inline="always")
def _spring_force(c, indices, rest, stiffness, damping, cur, velocity):
    """(f_x, f_y, f_z): the force of spring c on its first particle (minus it on the second)."""
    zero = np.float32(0.0)
    a = indices[c, 0]
    b = indices[c, 1]
    dx = cur[b, 0] - cur[a, 0]
    dy = cur[b, 1] - cur[a, 1]
    dz = cur[b, 2] - cur[a, 2]
    length = np.sqrt(dx * dx + dy * dy + dz * dz)
    if length == zero:
        return zero * dx, zero * dy, zero * dz
    ux = dx / length
    uy = dy / length
    uz = dz / length
    rx = velocity[b, 0] - velocity[a, 0]
    ry = velocity[b, 1] - velocity[a, 1]
    rz = velocity[b, 2] - velocity[a, 2]
    f = stiffness[c] * (length - rest[c]) + damping[c] * (rx * ux + ry * uy + rz * uz)
    return f * ux, f * uy, f * uz


@kernel
def spring_forces(indices, rest, stiffness, damping, cur, velocity, force):
    """indices (c,2), rest/stiffness/damping (c,) (scene units, kg/s^2, kg/s); cur (n,4)
    positions and inverse masses; velocity (n,3); force (n,3) is added to (kg * units / s^2),
    pinned particles' slots included."""
    for c in range(indices.shape[0]):
        fx, fy, fz = _spring_force(c, indices, rest, stiffness, damping, cur, velocity)
        a = indices[c, 0]
        b = indices[c, 1]
        force[a, 0] += fx
        force[a, 1] += fy
        force[a, 2] += fz
        force[b, 0] -= fx
        force[b, 1] -= fy
        force[b, 2] -= fz


@kernel(parallel=True)
def spring_forces_sets(indices, rest, stiffness, damping, set_offsets, cur, velocity, force):
    """As ``spring_forces`` for the springs of the conflict-free sets set_offsets (s+1,),
    each set in parallel; only movable particles (cur.w > 0) are written."""
    zero = np.float32(0.0)
    for s in range(set_offsets.shape[0] - 1):
        for c in numba.prange(set_offsets[s], set_offsets[s + 1]):
            fx, fy, fz = _spring_force(c, indices, rest, stiffness, damping, cur, velocity)
            a = indices[c, 0]
            b = indices[c, 1]
            if cur[a, 3] > zero:
                force[a, 0] += fx
                force[a, 1] += fy
                force[a, 2] += fz
            if cur[b, 3] > zero:
                force[b, 0] -= fx
                force[b, 1] -= fy
                force[b, 2] -= fz
