"""Which faces need face collision: the triangles a sphere or capsule can sink into between particles.

A sphere or capsule of radius r held off by particle collision alone can still push a face
between particles into itself: the collider's surface bulges rho^2 / (2 R) (R = r + margin)
past a chord of half-length rho, so a face whose corners are a few centimetres apart sinks
millimetres into a leg. The points of a triangle farthest from its corners are at most its
circumradius away from them, so a triangle whose circumradius is at most
hole = sqrt(2 R t) (a bulge of at most the margin's thickness ``t``) is held off by its
corners' particles alone. Every larger triangle collides as a face with the spheres and
capsules (clothtool.solver.kernels.collide_faces: its deepest point against each), sized at
bake time for the scene's smallest sphere or capsule.
"""

from __future__ import annotations

import numpy as np


def _lengths(v: np.ndarray) -> np.ndarray:
    """Lengths of the vectors whose x, y, z are the rows of (3,t) ``v``, summed x, y, z in
    turn as np.linalg.norm(axis=-1) sums them (the same bits, without its strided overhead)."""
    return np.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])


def _circumradius(corners: np.ndarray) -> np.ndarray:
    """(t,) circumradius of (t,3,3) triangle ``corners`` (its longest edge when degenerate)."""
    p = np.ascontiguousarray(np.moveaxis(corners, 0, -1))  # (corner, axis, triangle): contiguous rows
    u, w = p[1] - p[0], p[2] - p[0]
    a = _lengths(p[1] - p[2])
    b = _lengths(w)
    c = _lengths(u)  # |c0 - c1|: negating a vector is exact
    twice_area = _lengths(np.stack([u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2], u[0] * w[1] - u[1] * w[0]]))
    return np.where(twice_area > 0, a * b * c / np.maximum(2.0 * twice_area, 1e-300), np.maximum(np.maximum(a, b), c))


def needs_face_collision(points: np.ndarray, triangles: np.ndarray, radius: float, margin: float) -> np.ndarray:
    """bool (t,): whether each triangle's corners leave a hole that colliders of radius at
    least ``radius`` held off at ``margin`` (same length unit as ``points``) bulge into by more
    than the margin (see the module docstring)."""
    if triangles.shape[0] == 0 or not margin > 0:
        return np.zeros(triangles.shape[0], bool)
    # np.take gathers the same rows as indexing with the (t,3) array, in a fifth of the time
    corners = np.take(np.asarray(points, np.float64), triangles, axis=0)
    hole = np.sqrt(2.0 * (radius + margin) * margin)  # the largest rho whose bulge is <= margin
    return _circumradius(corners) > hole


def face_triangles(points: np.ndarray, triangles: np.ndarray, radius: float, margin: float) -> np.ndarray:
    """i32 (f,3): the triangles of ``triangles`` that need face collision, in order."""
    return np.ascontiguousarray(triangles[needs_face_collision(points, triangles, radius, margin)], np.int32)
