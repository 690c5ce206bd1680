"""Reference for clothtool.integrators.explicit.kernels.explicit_collide (from its docstring),
on the shared geometry's reference (tests/reference/collide.py ``point_correction``): every
movable particle (cur.w > 0) moves by the correction c = continuous move + average push-out,
loses its inward velocity along c / |c| relative to the surface velocity (shift / h, or the
velocity of its corrected path after a continuous move, then without friction), has its tangential velocity
reduced by Coulomb friction mu |v_n| (mu = budget / |push|) and gets prev = x - h v. Float64."""

from __future__ import annotations

import numpy as np

from tests.reference.collide import point_correction


def collide_colliders(shapes, mesh, frame, h, cur, prev, velocity):
    """(cur, prev, velocity) after collision, float64 copies."""
    cur, prev, velocity = (np.array(a, np.float64) for a in (cur, prev, velocity))
    for i in range(cur.shape[0]):
        if not cur[i, 3] > 0:
            continue
        p, q = cur[i, :3].copy(), prev[i, :3].copy()
        count, moved, push, shift, budget = point_correction(p, q, shapes, mesh, frame, True)
        c = moved + push
        size = np.linalg.norm(c)
        if size == 0:
            continue
        target, normal = p + c, c / size
        if not moved.any():
            mu = budget / np.linalg.norm(push) if np.linalg.norm(push) > 0 else 0.0
            surface = shift / h
        else:
            mu, surface = 0.0, (target - q) / h
        _respond(i, target, normal, surface, mu, h, cur, prev, velocity)
    return cur, prev, velocity


def _respond(i, target, normal, surface, mu, h, cur, prev, velocity):
    """Apply one contact to particle i in place (float64 arrays): move to ``target``, remove
    the inward relative normal velocity, Coulomb friction, prev = x - h v."""
    cur[i, :3] = target
    r = velocity[i] - surface
    rn = float(r @ normal)
    if rn < 0.0:
        tangent = r - rn * normal
        slide = float(np.linalg.norm(tangent))
        keep = max(0.0, 1.0 - mu * abs(rn) / slide) if slide > 0.0 else 0.0
        velocity[i] = surface + keep * tangent
    prev[i, :3] = cur[i, :3] - h * velocity[i]
