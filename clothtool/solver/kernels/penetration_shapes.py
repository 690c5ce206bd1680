"""How deep a cloth's faces reach into spheres and capsules: the measurement behind a bake's
``max_penetration`` and ``faces_beyond_thickness`` (clothtool.solver.penetration).

For every triangle and every round cone (a sphere, or a capsule: the hull of two spheres,
radii grown by the collider's margin) that can reach it, the triangle's least signed
distance from the cone: exactly, from the candidates of collide_faces.capsule_deepest (the
end spheres' closest points, each edge's closed-form minimum, the axis crossing), all of
them scored. The face collision pushes out the same deepest points; its own tests hold that
search to a grid-search reference (tests/kernels/test_collide_faces.py), and this module's
to the measure's former grid search (tests/reference/penetration_shapes.py).
"""

from __future__ import annotations

import numpy as np

from clothtool._jit import kernel
from clothtool._minmax import largest, smallest
from clothtool.solver.kernels.collide_faces import _capsule_terms, capsule_deepest
from clothtool.solver.kernels.collide_shapes import capsule_axis, round_cone_distance

# A cone's box test skips a triangle only when the centroid's distance from the box exceeds
# the reach by this relative margin: the exact test below would skip it too, whatever its
# rounding (the distance from the cone is at least the distance from its box).
BOX_MARGIN = 1e-6


@kernel
def round_cone_depths(points, triangles, cones, depth):
    """depth[t] = max(depth[t], minus the least signed distance of triangle t from each round
    cone that can reach it). ``cones``: (q, CAPSULE_COLUMNS) capsule records with their ends
    and radii in columns 8-15 (a sphere: both ends alike); their axis terms (columns 17-23)
    are filled here. A cone reaches a triangle only when its distance from the triangle's
    centroid is at most the triangle's bounding radius (the distance is 1-Lipschitz): the
    others are skipped, so a triangle near none keeps its depth (-inf to start with). Most
    are told apart by the cone's box (a few multiplications) before its exact distance."""
    boxes = np.empty((cones.shape[0], 6))
    for q in range(cones.shape[0]):
        capsule_axis(cones, q)
        for d in range(3):
            boxes[q, d] = smallest(cones[q, 8 + d] - cones[q, 11], cones[q, 12 + d] - cones[q, 15])
            boxes[q, 3 + d] = largest(cones[q, 8 + d] + cones[q, 11], cones[q, 12 + d] + cones[q, 15])
    for t in range(triangles.shape[0]):
        a, b, c = triangles[t, 0], triangles[t, 1], triangles[t, 2]
        p0x, p0y, p0z = points[a, 0], points[a, 1], points[a, 2]
        p1x, p1y, p1z = points[b, 0], points[b, 1], points[b, 2]
        p2x, p2y, p2z = points[c, 0], points[c, 1], points[c, 2]
        cx, cy, cz = (p0x + p1x + p2x) / 3.0, (p0y + p1y + p2y) / 3.0, (p0z + p1z + p2z) / 3.0
        reach_sqr = largest((p0x - cx) ** 2 + (p0y - cy) ** 2 + (p0z - cz) ** 2,
                        (p1x - cx) ** 2 + (p1y - cy) ** 2 + (p1z - cz) ** 2,
                        (p2x - cx) ** 2 + (p2y - cy) ** 2 + (p2z - cz) ** 2)
        reach = np.sqrt(reach_sqr)
        for q in range(cones.shape[0]):
            ex = largest(boxes[q, 0] - cx, cx - boxes[q, 3], 0.0)
            ey = largest(boxes[q, 1] - cy, cy - boxes[q, 4], 0.0)
            ez = largest(boxes[q, 2] - cz, cz - boxes[q, 5], 0.0)
            if ex * ex + ey * ey + ez * ez > reach_sqr * (1.0 + BOX_MARGIN) ** 2:
                continue
            near = round_cone_distance(cx, cy, cz, cones[q, 8], cones[q, 9], cones[q, 10], cones[q, 11], cones[q, 12],
                                       cones[q, 13], cones[q, 14], cones[q, 15])[0]
            if near > reach:
                continue
            g = capsule_deepest(p0x, p0y, p0z, p1x, p1y, p1z, p2x, p2y, p2z, _capsule_terms(cones, q), True)[0]
            depth[t] = largest(depth[t], -g)
