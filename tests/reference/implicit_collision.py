"""Reference for clothtool/integrators/implicit/kernels/implicit_collision.py, written from
its docstring in float64 numpy on the shared geometry's reference
(tests/reference/collide.py ``point_correction``): a contact is (phi, n, mu, collider
velocity) of the correction c = move + push, phi = -|c|; steps 1-3 (repulsion at the start
positions, inelastic impulses with Coulomb friction for the paths to the end) and step 4
(the final correction without friction, then no inward relative velocity kept)."""

from __future__ import annotations

import numpy as np

from tests.reference.collide import point_correction

NONE = (1e30, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)


def contact(shapes, mesh, frame, p0, p1, h, continuous):
    """(contact 8-tuple, correction (3,)) of the point moving p0 -> p1 over the step h."""
    count, moved, push, shift, budget = point_correction(p1, p0, shapes, mesh, frame, continuous)
    c = moved + push
    size = np.linalg.norm(c)
    if size <= 1e-7 * (1 + np.abs(p1).max()):
        return NONE, np.zeros(3)
    if not moved.any():
        friction = budget / np.linalg.norm(push) if np.linalg.norm(push) > 0 else 0.0
        velocity = shift / h
    else:
        friction, velocity = 0.0, (p1 + c - p0) / h
    return (-size, *(c / size), friction, *velocity), c


def _impulse(v, dvn, found):
    n, mu, vc = np.array(found[1:4]), found[4], np.array(found[5:8])
    v = v + dvn * n
    relative = v - vc
    tangent = relative - (relative @ n) * n
    speed = np.linalg.norm(tangent)
    if speed > 0 and mu > 0 and dvn > 0:
        v = v + (max(1 - mu * dvn / speed, 0.0) - 1) * tangent
    return v


def collide_particles(shapes, mesh, frame, x0, mass, free, stiffness, h, passes, v_mid, v_end):
    """Steps 1-3; returns (v_mid, v_end, contact (n,8)) as new arrays."""
    v_mid, v_end = np.array(v_mid, np.float64), np.array(v_end, np.float64)
    contacts = np.tile(np.array(NONE), (x0.shape[0], 1))
    for i in range(x0.shape[0]):
        if not free[i]:
            continue
        p0 = np.asarray(x0[i], np.float64)
        v, last = v_mid[i].copy(), None
        found, _ = contact(shapes, mesh, frame, p0, p0, h, False)
        d = -found[0]
        if found[0] < 1e30:
            vr = (v - np.array(found[5:8])) @ np.array(found[1:4])
            if vr < 0.1 * d / h:
                v = _impulse(v, min(h * stiffness * d / mass[i], 0.1 * d / h - vr), found)
                last = found
        for _ in range(passes):
            found, _ = contact(shapes, mesh, frame, p0, p0 + h * v, h, True)
            if found[0] >= 1e30:
                break
            v = _impulse(v, -found[0] / h, found)
            last = found
        v_end[i] += v - v_mid[i]
        v_mid[i] = v
        if last is not None:
            contacts[i] = last
    return v_mid, v_end, contacts


def project_particles(shapes, mesh, frame, x0, free, h, v_mid, v_end, contacts):
    """Step 4; returns (v_mid, v_end, contact) as new arrays."""
    v_mid, v_end, contacts = (np.array(a, np.float64) for a in (v_mid, v_end, contacts))
    for i in range(x0.shape[0]):
        if not free[i]:
            continue
        p0 = np.asarray(x0[i], np.float64)
        found, c = contact(shapes, mesh, frame, p0, p0 + h * v_mid[i], h, True)
        if found[0] < 1e30:
            v_mid[i] = v_mid[i] + c / h
            contacts[i] = found
        if contacts[i, 0] < 1e30:
            n, vc = contacts[i, 1:4], contacts[i, 5:8]
            inward = (v_end[i] - vc) @ n
            if inward < 0:
                v_end[i] = v_end[i] - inward * n
    return v_mid, v_end, contacts
