"""Face collision points: virtual particles inside the triangles, sized to the colliders.

A sphere or capsule of radius r held off by particle collision alone can still push a face
between particles into itself: over a gap g between collision points held at R = r + margin,
the surface bulges g^2 / (8 R) past the points' chord, and a face whose corners are a few
centimetres apart sinks millimetres into a leg. So at bake time, for the smallest sphere or
capsule radius of the scene, every triangle whose corners leave too large a hole gets
collision points at the centroids of its level-n subdivision (n^2 small triangles), with n
the smallest level at which every point of the triangle is within rho of a collision point,
where the collider's bulge over rho, rho^2 / (2 R), is at most the margin's thickness ``t``:
a face then stays outside the collider's own surface wherever its points are held at the
margin. rho for level n is the distance of a small triangle's corners from its centroid:
(2/3) of the triangle's longest median over n; with no points (level 0) it is the
triangle's circumradius (the corners are the particles themselves).

The points are rows of (particle i, j, k, weight row) like the fabric's cooked virtual
particles, and collide the same way (clothtool.solver.kernels.collide.collide_virtual).
"""

from __future__ import annotations

import numpy as np

# The finest subdivision (level^2 points per triangle); beyond it a triangle keeps the cap.
MAX_LEVEL = 6


def subdivision_weights(level: int) -> np.ndarray:
    """(level^2, 3) barycentric centroids of the small triangles of a level-``level`` subdivision."""
    rows = []
    for i in range(level):
        for j in range(level - i):
            rows.append((i + 1 / 3, j + 1 / 3, level - i - j - 2 / 3))  # upright small triangle
            if i + j < level - 1:
                rows.append((i + 2 / 3, j + 2 / 3, level - i - j - 4 / 3))  # inverted one
    return np.asarray(rows, np.float64) / level


def _longest_median(corners: np.ndarray) -> np.ndarray:
    centroid = corners.mean(axis=1, keepdims=True)
    return 1.5 * np.linalg.norm(corners - centroid, axis=-1).max(axis=1)


def _circumradius(corners: np.ndarray) -> np.ndarray:
    a = np.linalg.norm(corners[:, 1] - corners[:, 2], axis=-1)
    b = np.linalg.norm(corners[:, 2] - corners[:, 0], axis=-1)
    c = np.linalg.norm(corners[:, 0] - corners[:, 1], axis=-1)
    twice_area = np.linalg.norm(np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]), axis=-1)
    return np.where(twice_area > 0, a * b * c / np.maximum(2.0 * twice_area, 1e-300), np.maximum(np.maximum(a, b), c))


def face_levels(points: np.ndarray, triangles: np.ndarray, radius: float, margin: float) -> np.ndarray:
    """i64 (t,) subdivision level per triangle (0: no points needed) for colliders of radius
    at least ``radius`` held off at ``margin`` (same length unit as ``points``)."""
    if triangles.shape[0] == 0 or not margin > 0:
        return np.zeros(triangles.shape[0], np.int64)
    corners = np.asarray(points, np.float64)[triangles]
    hole = np.sqrt(2.0 * (radius + margin) * margin)  # the largest rho whose bulge is <= margin
    needed = np.ceil((2.0 / 3.0) * _longest_median(corners) / hole).astype(np.int64)
    level = np.where(_circumradius(corners) <= hole, 0, np.maximum(needed, 1))
    return np.minimum(level, MAX_LEVEL)


def face_points(points: np.ndarray, triangles: np.ndarray, radius: float, margin: float) -> tuple[np.ndarray, np.ndarray]:
    """(rows i32 (v,4), weights f64 (w,3)): collision points for every triangle that needs
    them (see the module docstring), in triangle order; each row's last entry indexes
    ``weights``, which holds the patterns of levels 1..max level used, one after another."""
    levels = face_levels(points, triangles, radius, margin)
    used = np.unique(levels[levels > 0])
    if used.shape[0] == 0:
        return np.zeros((0, 4), np.int32), np.zeros((0, 3), np.float64)
    patterns = [subdivision_weights(int(n)) for n in used]
    first = np.zeros(MAX_LEVEL + 1, np.int64)  # level -> its pattern's first row in the weights
    first[used] = np.cumsum([0] + [p.shape[0] for p in patterns[:-1]])
    counts = levels * levels
    owner = np.repeat(np.arange(triangles.shape[0]), counts)
    start = np.repeat(np.cumsum(counts) - counts, counts)
    within = np.arange(owner.shape[0]) - start
    offset = first[levels]
    rows = np.empty((owner.shape[0], 4), np.int32)
    rows[:, :3] = triangles[owner]
    rows[:, 3] = offset[owner] + within
    return rows, np.concatenate(patterns)
