"""The wind stage solves triangles colour by colour (triangles of a colour share no particle):
the seed's update in another triangle order, which must still be a valid conflict-free order
covering every triangle once."""

from __future__ import annotations

import numpy as np

from clothtool.solver.config import Material


def test_wind_stage_orders_every_triangle_once_by_colour(grid_fabric, solver_for):
    fabric = grid_fabric(12, 9, 0.05, plane="XZ")
    solver = solver_for(fabric, material=Material(areal_density=0.2, drag_coefficient=1.0), wind=lambda t: np.array([1.0, 0.0, 0.0]))
    stage = next(stage for stage in solver.stages if stage.name == "wind")
    ordered = stage.triangles
    original = solver.model.triangles
    # the same triangles, each once
    assert sorted(map(tuple, ordered.tolist())) == sorted(map(tuple, original.tolist()))
    # consecutive runs of particle-disjoint triangles, fewer runs than triangles
    runs, used = 1, set()
    for triangle in ordered.tolist():
        if used & set(triangle):
            runs, used = runs + 1, set()
        used |= set(triangle)
    assert runs < len(ordered) // 4
