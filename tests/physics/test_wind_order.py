"""The wind stage solves triangles colour by colour (triangles of a colour share no movable
particle): the seed's update in another triangle order, which must still be a valid
conflict-free order covering every triangle once."""

from __future__ import annotations

import numpy as np

from clothtool.settings import Material


def test_wind_stage_orders_every_triangle_once_by_colour(grid_fabric, solver_for):
    fabric = grid_fabric(12, 9, 0.05, plane="XZ", pin_box=(-1.0, -1.0, -1.0, 1.0, 1.0, 0.01))
    solver = solver_for(fabric, material=Material(areal_density=0.2, drag_coefficient=1.0), wind=lambda t: np.array([1.0, 0.0, 0.0]))
    stage = next(stage for stage in solver.stages if stage.name == "wind")
    ordered = stage.triangles
    original = solver.model.triangles
    # the same triangles, each once
    assert sorted(map(tuple, ordered.tolist())) == sorted(map(tuple, original.tolist()))
    # each colour's triangles share no movable particle; few colours
    offsets = stage.color_offsets
    movable = solver.model.inv_mass > 0
    for k in range(len(offsets) - 1):
        corners = ordered[offsets[k] : offsets[k + 1]].ravel()
        corners = corners[movable[corners]]
        assert np.unique(corners).size == corners.size
    assert offsets[0] == 0 and offsets[-1] == len(ordered) and len(offsets) - 1 <= 12
