"""References for clothtool/solver/kernels/collide.py, composed from the shape and mesh
references and written from the kernel module's docstring: contacts are averaged, friction
removes min(1, mean(mu |push|) / |tangential relative displacement|) of the tangential
relative displacement, the inverse mass is scaled by 1 / (1 + s |push in m|^2), continuous
collision puts a particle that would end beyond a sphere or capsule back on its surface where
it hit. Results are float64 copies; the inputs are left alone."""

from __future__ import annotations

import numpy as np

from tests.reference import collide_mesh as mesh_ref
from tests.reference import collide_shapes as shapes


def weighted_point(state, a, b, c, wa, wb, wc):
    s = np.asarray(state, np.float64)
    return tuple(wa * s[a, :3] + wb * s[b, :3] + wc * s[c, :3])


def movable_weights(cur, prev, a, b, c, wa, wb, wc):
    """The weights of the corners free (w > 0) at both ends of the iteration, else 0, and
    the sum of their squares."""
    kept = [w if prev[i, 3] > 0 and cur[i, 3] > 0 else 0.0 for i, w in zip((a, b, c), (wa, wb, wc))]
    return (*kept, float(np.dot(kept, kept)))

def share_out(cur, a, b, c, ma, mb, mc, norm, cx, cy, cz, scale, cap):
    """Returns cur with each corner of nonzero kept weight m moved by c min(m / norm, cap)
    and its w scaled by 1 + (scale - 1) m."""
    out = np.array(cur, np.float64)
    for particle, m in ((a, ma), (b, mb), (c, mc)):
        if m != 0.0:
            out[particle, :3] += np.array([cx, cy, cz]) * min(m / norm, cap)
            out[particle, 3] *= 1.0 + (scale - 1.0) * m
    return out


def _unit(x, y, z):
    v = np.asarray([x, y, z], np.float64)
    length = np.linalg.norm(v)
    return (0.0, 1.0, 0.0) if length <= 1e-12 else tuple(v / length)


def continuous_contact(px, py, pz, qx, qy, qz, sphere_data, capsule_data):
    p, q = np.array([px, py, pz], np.float64), np.array([qx, qy, qz], np.float64)
    best, result = 2.0, p
    for row in np.asarray(sphere_data, np.float64):
        c0, r0, c1, r1 = row[0:3], row[3], row[4:7], row[7]
        t = shapes.sphere_time_of_impact(*q, *p, *c0, r0, *c1, r1)
        if t < 0 or t >= best:
            continue
        hit = np.array(_unit(*((q + t * (p - q)) - (c0 + t * (c1 - c0)))))
        end_normal = np.array(shapes.sphere_distance(*p, *c1, r1)[1:])
        if end_normal @ hit >= 0:
            continue
        best, result = t, c1 + r1 * hit
    for c in range(capsule_data.shape[0]):
        t, *hit, sigma = shapes.capsule_time_of_impact(*q, *p, capsule_data, c)
        if t < 0 or t >= best:
            continue
        end = np.asarray(capsule_data[c, 8:16], np.float64)
        end_normal = np.array(shapes.round_cone_distance(*p, *end)[1:4])
        if end_normal @ hit >= 0:
            continue
        at = shapes.capsule_at(capsule_data, c, t)
        axis_t = np.array(_unit(*(np.subtract(at[4:7], at[0:3]))))
        axis_1 = np.array(_unit(*(end[4:7] - end[0:3])))
        normal = np.array(shapes.rotate_between(*axis_t, *axis_1, *hit))
        centre = (1 - sigma) * end[0:3] + sigma * end[4:7]
        radius = (1 - sigma) * end[3] + sigma * end[7]
        best, result = t, centre + radius * normal
    return (best <= 1.0, *result)


def _accumulate(contacts):
    """(count, push sum, shift sum, budget) from (push, shift, mu) triples."""
    push = sum((c[0] for c in contacts), np.zeros(3))
    shift = sum((c[1] for c in contacts), np.zeros(3))
    budget = sum(c[2] * np.linalg.norm(c[0]) for c in contacts)
    return (len(contacts), *push, *shift, budget)


def _sphere_list(p, sphere_data):
    out = []
    for row in np.asarray(sphere_data, np.float64):
        d, *n = shapes.sphere_distance(*p, *row[4:7], row[7])
        if d < 0:
            out.append((-d * np.array(n), row[4:7] - row[0:3], row[8]))
    return out


def sphere_contacts(px, py, pz, sphere_data):
    return _accumulate(_sphere_list((px, py, pz), sphere_data))


def _capsule_list(p, capsule_data):
    out = []
    for row in np.asarray(capsule_data, np.float64):
        d, nx, ny, nz, sigma = shapes.round_cone_distance(*p, *row[8:16])
        if d < 0:
            shift = (1 - sigma) * (row[8:11] - row[0:3]) + sigma * (row[12:15] - row[4:7])
            out.append((-d * np.array([nx, ny, nz]), shift, row[16]))
    return out


def capsule_contacts(px, py, pz, capsule_data):
    return _accumulate(_capsule_list((px, py, pz), capsule_data))


def frame_motion(frame, x, y, z):
    """Local end position minus local start position of the world point at local x (end)."""
    f = np.asarray(frame, np.float64)
    local = np.array([x, y, z], np.float64)
    world = f[4:7] @ local + f[7]
    return tuple(local - f[0:3].T @ (world - f[3]))


def _convex_list(p, planes, offsets, convex_data, frame):
    out = []
    for k in range(len(offsets) - 1):
        margin, mu = float(convex_data[k, 0]), float(convex_data[k, 1])
        d, *n = shapes.convex_distance(*p, planes, offsets[k], offsets[k + 1], margin)
        if d < 0:
            push = -d * np.array(n)
            surface = np.asarray(p, np.float64) + push
            shift = np.array(frame_motion(frame, *surface)) + np.asarray(convex_data[k, 2:5], np.float64)
            out.append((push, shift, mu))
    return out


def convex_contacts(px, py, pz, planes, offsets, convex_data, frame):
    return _accumulate(_convex_list((px, py, pz), planes, offsets, convex_data, frame))


def friction_correction(px, py, pz, qx, qy, qz, dx, dy, dz, sx, sy, sz, budget):
    relative = np.array([px - qx - sx, py - qy - sy, pz - qz - sz], np.float64)
    push = np.array([dx, dy, dz], np.float64)
    if np.linalg.norm(push) > 1e-12:
        n = push / np.linalg.norm(push)
        relative -= (relative @ n) * n
    tangential = np.linalg.norm(relative)
    if tangential <= 1e-12 or budget <= 0:
        return 0.0, 0.0, 0.0
    return tuple(-min(1.0, budget / tangential) * relative)


def _contacts(p, q, shapes_group, mesh, frame):
    sphere_data, capsule_data, planes, offsets, convex_data = shapes_group
    found = _sphere_list(p, sphere_data) + _capsule_list(p, capsule_data)
    found += _convex_list(p, planes, offsets, convex_data, frame)
    hit, *rest = mesh_ref.mesh_contact(*p, *q, *mesh[:1], *mesh[1:], frame)
    if hit:
        found.append((np.array(rest[0:3]), np.array(rest[3:6]), rest[6]))
    return found


def _add_contacts(total, part):
    """Elementwise sum of two contact summaries."""
    return tuple(t + q for t, q in zip(total, part))


def _mesh_summary(found):
    """mesh_contact's (hit, push xyz, surface motion xyz, mu) as a contact summary."""
    hit, *rest = found
    if not hit:
        return (0,) + (0.0,) * 7
    return (1, *rest[:6], rest[6] * float(np.linalg.norm(rest[0:3])))


def _resolve(p, q, found):
    """(correction, push) of a point at p (previous q) with contacts ``found``."""
    count = len(found)
    push = sum((c[0] for c in found), np.zeros(3)) / count
    shift = sum((c[1] for c in found), np.zeros(3)) / count
    budget = sum(c[2] * np.linalg.norm(c[0]) for c in found) / count
    friction = np.array(friction_correction(*(p + push), *q, *push, *shift, budget))
    return push + friction, push


def collide_particles(shapes_group, mesh, frame, prev, continuous, mass_scale, meters_per_unit, cur):
    """(cur, prev) after collision, float64."""
    cur = np.asarray(cur, np.float64).copy()
    prev = np.asarray(prev, np.float64).copy()
    for i in range(cur.shape[0]):
        if prev[i, 3] == 0 or cur[i, 3] == 0:
            continue
        p, q = cur[i, :3].copy(), prev[i, :3]
        if continuous:
            _, *moved = continuous_contact(*p, *q, shapes_group[0], shapes_group[1])
            p = np.array(moved)
        found = _contacts(p, q, shapes_group, mesh, frame)
        if found:
            correction, push = _resolve(p, q, found)
            p = p + correction
            if mass_scale > 0:
                cur[i, 3] /= 1 + mass_scale * (push @ push) * meters_per_unit**2
        cur[i, :3] = p
    return cur, prev


collide_particles_parallel = collide_particles


def collide_virtual(virtual, weights, shapes_group, mesh, frame, prev, continuous, mass_scale, meters_per_unit, cur):
    cur = np.asarray(cur, np.float64).copy()
    prev = np.asarray(prev, np.float64).copy()
    for row in virtual:
        index, w = row[:3], np.asarray(weights[row[3]], np.float64)
        movable = (prev[index, 3] > 0) & (cur[index, 3] > 0)
        if not movable.any():
            continue
        p, q = w @ cur[index, :3], w @ prev[index, :3]
        moved = np.zeros(3)
        if continuous:
            _, *end = continuous_contact(*p, *q, shapes_group[0], shapes_group[1])
            moved = np.array(end) - p
            p = p + moved
        found = _contacts(p, q, shapes_group, mesh, frame)
        if not found and not moved.any():
            continue
        correction, push = _resolve(p, q, found) if found else (np.zeros(3), np.zeros(3))
        correction = correction + moved
        share = np.where(movable, w, 0.0) / np.sum(np.where(movable, w, 0.0) ** 2)
        scale = 1.0 / (1 + mass_scale * (push @ push) * meters_per_unit**2) if mass_scale > 0 and found else 1.0
        for k in range(3):
            if movable[k]:
                cur[index[k], :3] += correction * share[k]
                cur[index[k], 3] *= 1 + (scale - 1) * w[k]
    return cur, prev


def point_correction(p, q, shapes_group, mesh, frame, continuous):
    """(count, move (3,), average push (3,), average shift (3,), average budget) of the point
    moving q -> p: kernels.collide.point_correction, float64."""
    p, q = np.asarray(p, np.float64), np.asarray(q, np.float64)
    moved = np.zeros(3)
    if continuous:
        _, *end = continuous_contact(*p, *q, shapes_group[0], shapes_group[1])
        moved = np.array(end) - p
    found = _contacts(p + moved, q, shapes_group, mesh, frame)
    if not found:
        return 0, moved, np.zeros(3), np.zeros(3), 0.0
    count = len(found)
    push = sum((c[0] for c in found), np.zeros(3)) / count
    shift = sum((c[1] for c in found), np.zeros(3)) / count
    budget = sum(c[2] * np.linalg.norm(c[0]) for c in found) / count
    return count, moved, push, shift, budget


# The kernel's point_correction variants kept to fewer collider kinds (collide_virtual picks
# one for the scene's kinds): the same geometry whenever the kinds left out are absent.
_spheres_only = _spheres_continuous = point_correction
_with_convexes = _with_convexes_continuous = point_correction
_with_meshes = _with_meshes_continuous = _with_both = point_correction
