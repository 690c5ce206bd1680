"""Face collision against triangle-mesh colliders: which collider points collide with the cloth's faces.

A mesh collider's vertices collide with the cloth's faces, and so do samples along its
edges: a ridge (the long edge of a low-poly leg, a table's edge) crossing a face between
particles touches the face at no vertex. Samples are spaced at most ``SAMPLE_SPACING`` of the
cloth's median rest edge length apart: the distance from a straight ridge to a flat face is
linear along the ridge, so between two samples held off a face at the margin the ridge
stays off it too; the fraction leaves room for the cloth folding over the ridge between two
triangles. Every vertex and edge is tested once, by the first triangle that holds it
(clothtool.solver.kernels.collide_mesh_faces runs the test).
"""

from __future__ import annotations

import numpy as np

# Collider edge samples at most this fraction of the cloth's median rest edge length apart.
SAMPLE_SPACING = 0.25
# At most this many samples inside one collider edge (a collider edge far longer than the
# cloth's edges, a floor's, keeps this cap: its ends and the particles still collide).
MAX_EDGE_SAMPLES = 32


def sample_spacing(rest_pos: np.ndarray, triangles: np.ndarray) -> float:
    """Largest spacing of collider edge samples for a cloth (its scene units): SAMPLE_SPACING
    of its median rest edge length; inf for a cloth without triangles."""
    if triangles.shape[0] == 0:
        return float("inf")
    corners = np.asarray(rest_pos, np.float64)[triangles]
    lengths = np.linalg.norm(corners - np.roll(corners, -1, axis=1), axis=-1)
    return SAMPLE_SPACING * float(np.median(lengths))


def collider_owners(triangles: np.ndarray, points: np.ndarray, spacing: float) -> np.ndarray:
    """i32 (t,4): per collider triangle the bit mask of the corners it owns (bit 0-2: a, b, c)
    and the number of samples inside each of its edges ab, bc, ca it owns (zero for an edge
    another triangle owns): every vertex and edge is owned by the first triangle holding it,
    and an edge of length L gets ceil(L / spacing) - 1 samples (at most MAX_EDGE_SAMPLES)."""
    t = triangles.shape[0]
    owners = np.zeros((t, 4), np.int32)
    if t == 0:
        return owners
    _, first = np.unique(triangles.ravel(), return_index=True)
    np.bitwise_or.at(owners[:, 0], first // 3, (1 << (first % 3)).astype(np.int32))
    edges = np.sort(np.stack([triangles, np.roll(triangles, -1, axis=1)], axis=-1), axis=-1).reshape(-1, 2)
    _, first = np.unique(edges, axis=0, return_index=True)
    p = np.asarray(points, np.float64)
    lengths = np.linalg.norm(p[edges[first, 1]] - p[edges[first, 0]], axis=-1)
    with np.errstate(divide="ignore", invalid="ignore"):
        samples = np.ceil(lengths / spacing) - 1 if spacing > 0 else np.zeros_like(lengths)
    samples = np.clip(np.nan_to_num(samples, nan=0.0, posinf=MAX_EDGE_SAMPLES), 0, MAX_EDGE_SAMPLES)
    owners[first // 3, 1 + first % 3] = samples.astype(np.int32)
    return owners
