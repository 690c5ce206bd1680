"""How deep a cloth's faces sink into its sphere and capsule colliders (a measurement, numpy).

Particles can all stay outside a collider while the faces between them sink into it: a
capsule thinner than the cloth's edges slips between two particles. This measures the faces:
for every cloth triangle and every sphere or capsule (a round cone between two spheres) the
deepest point of the triangle inside the collider, i.e. minus the minimum over the triangle
of the collider's signed distance. The collider's surface includes its own thickness
(margin); the cloth's thickness is not subtracted: a face whose depth exceeds the cloth's
thickness is "beyond the thickness".

The minimum over a triangle is taken over a barycentric grid of points (corners and edges
included). The signed distance is 1-Lipschitz and smooth near a minimum inside a face or on an
edge, so a grid of spacing s misses the true depth by about s^2 / (8 r) for a collider of
radius r; the grid is chosen fine enough that this is at most ``ACCURACY`` of the cloth's
thickness (capped at ``MAX_LEVEL`` subdivisions per edge). Triangles far from every collider
(bounding spheres outside) are skipped, so the cost scales with the faces near the colliders.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from clothtool.solver.colliders import ColliderArrays

# The grid's sampling error bound, as a fraction of the cloth's thickness.
ACCURACY = 0.05
MAX_LEVEL = 24


@dataclasses.dataclass(frozen=True)
class FacePenetration:
    """depth: the deepest face point inside a collider in metres (<= 0 when no face is inside
    any: minus the smallest clearance, or -inf when no face is near a collider);
    faces_beyond: how many triangles sink deeper than the cloth's thickness."""

    depth: float
    faces_beyond: int


def barycentric_grid(level: int) -> np.ndarray:
    """(k,3) float64 barycentric points (i, j, level - i - j) / level, corners and edges included."""
    i, j = np.meshgrid(np.arange(level + 1), np.arange(level + 1), indexing="ij")
    keep = i + j <= level
    i, j = i[keep], j[keep]
    return np.stack([i, j, level - i - j], axis=1).astype(np.float64) / level


def round_cone_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray, ra: np.ndarray, rb: np.ndarray) -> np.ndarray:
    """Signed distance (negative inside) of points p (..., 3) to the convex hull of the spheres
    (a, ra) and (b, rb), each broadcast against p's leading axes (the exact round cone distance;
    a sphere when a == b)."""
    ba = b - a
    l2 = np.sum(ba * ba, axis=-1)
    degenerate = l2 <= 1e-30
    l2 = np.where(degenerate, 1.0, l2)
    rr = ra - rb
    a2 = l2 - rr * rr
    pa = p - a
    y = np.sum(pa * ba, axis=-1)
    z = y - l2
    x2 = np.sum((pa * l2[..., None] - ba * y[..., None]) ** 2, axis=-1)
    y2 = y * y * l2
    z2 = z * z * l2
    k = np.sign(rr) * rr * rr * x2
    near_b = np.sign(z) * a2 * z2 > k
    near_a = np.sign(y) * a2 * y2 < k
    side = (np.sqrt(np.maximum(x2 * a2 / l2, 0.0)) + y * rr) / l2 - ra
    distance = np.where(near_b, np.sqrt(x2 + z2) / l2 - rb, np.where(near_a, np.sqrt(x2 + y2) / l2 - ra, side))
    sphere = np.sqrt(np.sum(pa * pa, axis=-1)) - ra
    return np.where(degenerate, sphere, distance)


def _round_cones(colliders: ColliderArrays) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(a (q,3), b (q,3), ra (q,), rb (q,)) float64: every sphere collider (a == b) and capsule,
    radii grown by the collider's margin."""
    centers = colliders.sphere_center.astype(np.float64)
    radii = colliders.sphere_radius.astype(np.float64)
    spheres = np.flatnonzero(colliders.sphere_is_collider)
    ends = colliders.capsule_spheres
    a = np.concatenate([centers[spheres], centers[ends[:, 0]]])
    b = np.concatenate([centers[spheres], centers[ends[:, 1]]])
    margin = np.concatenate([colliders.sphere_margin[spheres], colliders.capsule_margin]).astype(np.float64)
    ra = np.concatenate([radii[spheres], radii[ends[:, 0]]]) + margin
    rb = np.concatenate([radii[spheres], radii[ends[:, 1]]]) + margin
    return a, b, ra, rb


def grid_level(edge: float, radius: float, thickness: float) -> int:
    """Subdivisions per edge so the grid's error (spacing^2 / (8 radius)) is at most
    ACCURACY * thickness (all lengths in the same unit)."""
    if edge <= 0.0:
        return 1
    spacing = np.sqrt(8.0 * max(radius, 1e-12) * ACCURACY * max(thickness, 1e-12))
    return int(min(MAX_LEVEL, max(1, np.ceil(edge / spacing))))


def face_penetration(
    points: np.ndarray, triangles: np.ndarray, colliders: ColliderArrays, meters_per_unit: float, thickness_m: float
) -> FacePenetration:
    """The faces' penetration of ``colliders`` (same space and scene units as ``points``).

    points: (n,3) cloth positions; triangles: i32 (t,3); thickness_m: the cloth's thickness in
    metres (the threshold of ``faces_beyond`` and the grid's accuracy scale).
    """
    a, b, ra, rb = _round_cones(colliders)
    if a.shape[0] == 0 or triangles.shape[0] == 0:
        return FacePenetration(-np.inf, 0)
    p = np.asarray(points, np.float64)
    corners = p[triangles]  # (t,3,3)
    centroid = corners.mean(axis=1)
    reach = np.linalg.norm(corners - centroid[:, None], axis=-1).max(axis=1)
    # the distance is 1-Lipschitz: a triangle reaches into a collider only when its centroid
    # is within the triangle's bounding radius of it
    near = round_cone_distance(centroid[:, None], a[None], b[None], ra[None], rb[None]) <= reach[:, None]
    tri, col = np.nonzero(near)
    if tri.shape[0] == 0:
        return FacePenetration(-np.inf, 0)
    thickness = thickness_m / meters_per_unit
    edges = np.linalg.norm(corners - np.roll(corners, 1, axis=1), axis=-1).max(axis=1)
    level = grid_level(float(edges[tri].max()), float(np.minimum(ra, rb)[col].min()), thickness)
    grid = barycentric_grid(level)  # (k,3)
    samples = np.einsum("kc,tcx->tkx", grid, corners[tri])  # (pairs,k,3)
    distance = round_cone_distance(
        samples, a[col][:, None], b[col][:, None], ra[col][:, None], rb[col][:, None]
    ).min(axis=1)
    depth_per_triangle = np.full(triangles.shape[0], -np.inf)
    np.maximum.at(depth_per_triangle, tri, -distance)
    depth = float(depth_per_triangle.max()) * meters_per_unit
    return FacePenetration(depth, int(np.count_nonzero(depth_per_triangle * meters_per_unit > thickness_m)))
