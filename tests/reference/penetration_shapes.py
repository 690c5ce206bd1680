"""Reference for clothtool.solver.kernels.penetration_shapes: the least signed distance of
each triangle from each round cone found by search (numpy, float64), not from the kernel's
candidate points. A barycentric grid of level COARSE, then ROUNDS times a hexagon of points
a third of the previous spacing apart around the best point so far (clipped to the
triangle): the signed distance of a convex body is convex, so the minimum lies next to the
best grid point, and the final spacing (the longest edge / (COARSE 3^ROUNDS)) leaves the
depth off by about spacing^2 / (8 (r - depth)): well under a micrometre for centimetre faces.
"""

from __future__ import annotations

import numpy as np

from clothtool.solver.penetration import barycentric_grid, round_cone_distance

COARSE = 6
ROUNDS = 4
STEPS = 3  # hexagon radius of a refinement round, in its own spacing


def _hexagon() -> np.ndarray:
    i, j = np.meshgrid(np.arange(-STEPS, STEPS + 1), np.arange(-STEPS, STEPS + 1), indexing="ij")
    keep = np.abs(i + j) <= STEPS
    return np.stack([i[keep], j[keep], -(i[keep] + j[keep])], axis=1).astype(np.float64)


def least_distance(corners, a, b, ra, rb) -> float:
    """The least signed distance over the triangle ``corners`` (3,3) from the round cone."""
    def distances(weights):
        return round_cone_distance(weights @ corners, a, b, ra, rb)

    grid = barycentric_grid(COARSE)
    values = distances(grid)
    centre, low = grid[np.argmin(values)], float(values.min())
    step = 1.0 / COARSE
    for _ in range(ROUNDS):
        step /= 3.0
        weights = np.clip(centre + step * _hexagon(), 0.0, None)
        weights /= weights.sum(axis=1, keepdims=True)
        values = distances(weights)
        centre, low = weights[np.argmin(values)], min(low, float(values.min()))
    return low


def round_cone_depths(points, triangles, cones, depth):
    """Returns ``depth`` with depth[t] raised to minus the triangle's least distance from every
    cone (ends and radii in columns 8-15) whose distance from its centroid is at most its
    bounding radius."""
    points = np.asarray(points, np.float64)
    depth = np.array(depth, np.float64)
    for t, triangle in enumerate(np.asarray(triangles)):
        corners = points[triangle]
        centroid = corners.mean(axis=0)
        reach = np.linalg.norm(corners - centroid, axis=1).max()
        for cone in np.asarray(cones, np.float64):
            a, ra, b, rb = cone[8:11], cone[11], cone[12:15], cone[15]
            if round_cone_distance(centroid, a, b, ra, rb) <= reach:
                depth[t] = max(depth[t], -least_distance(corners, a, b, ra, rb))
    return depth
