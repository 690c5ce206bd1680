"""How each particle shares in the air force of the triangles around it (all integrators).

The air law (``clothtool.solver.kernels.air``) gives each triangle a force F_t. A particle's
mass is its lumped area a_i times the areal density, and the cook lumps a polygon's area
evenly over the polygon's corners: a quad gives each corner a quarter, while a quad's two
triangles give the corners on its diagonal a third of each, so splitting F_t in thirds would
push a quad mesh's particles unevenly (the corners of a grid by 1/4 against 1/2 of their
share) and crumple a sheet that should fall flat. Instead particle i takes the fraction

    a_i / S_i        of each of its triangles' forces, S_i = the area of its triangles

so that under a uniform pressure q it feels q a_i, its own area's force: every particle then
accelerates alike and a flat sheet of any mesh falls at the textbook terminal speed. For a
triangle mesh (a_i = S_i / 3) the fraction is exactly a third. The arrays here hold
``share_i = 3 a_i / S_i`` (1 for a triangle mesh): the kernels give corner i
share_i times a third of its triangle's force. Both areas are taken relative to their
totals (a_i / sum a against S_i / sum S, sum S = 3 x the cloth's area), which makes the
shares independent of units and placement scale and keeps the cloth's total force the sum
of its triangles' forces. Rest-pose areas; a particle without triangles (or only degenerate
ones) gets 0.
"""

from __future__ import annotations

import numpy as np


def corner_shares(model) -> np.ndarray:
    """f32 (n,) share_i = 3 a_i / S_i of ``model`` (module docstring)."""
    n = model.particle_count
    tri = model.triangles
    # the areas as np.linalg.norm(np.cross(u, w), axis=1) gives them, with the same operations
    # on contiguous (t,) rows of the corners gathered at once (a third of the time at a bake's start)
    p = np.ascontiguousarray(np.moveaxis(np.take(model.rest_pos.astype(np.float64), tri, axis=0), 0, -1))
    (ux, uy, uz), (wx, wy, wz) = p[1] - p[0], p[2] - p[0]
    cx, cy, cz = uy * wz - uz * wy, uz * wx - ux * wz, ux * wy - uy * wx
    area = 0.5 * np.sqrt(cx * cx + cy * cy + cz * cz)
    # each particle's triangles' areas summed in the order np.add.at would add them corner by
    # corner (bincount adds its weights in order too: the same bits, a tenth of the time)
    around = np.bincount(tri.T.ravel(), np.tile(area, 3), minlength=n)[:n]
    lumped = model.mass / model.mass.sum() if n and model.mass.sum() > 0 else np.zeros(n)
    share = np.divide(lumped * around.sum(), around, out=np.zeros(n), where=around > 0)
    # a triangle mesh's shares are 1 up to rounding: make them exactly the thirds
    share[np.abs(share - 1.0) < 1e-6] = 1.0
    return share.astype(np.float32)
