"""What a cache frame stores of a cloth: f32 (n,3) world points and velocities in the mesh's
vertex order (a cook may renumber particles for locality; clothtool.fabric's vertex_particle)."""

from __future__ import annotations

import numpy as np

from clothtool.solver.kernels.rows import gather_xyz


def in_vertex_order(model, values: np.ndarray) -> np.ndarray:
    """f32 (n,3) per-particle ``values`` in the mesh's vertex order, gathered and converted in
    one pass (the writers take float32)."""
    order = model.fabric.vertex_particle
    if order is None:
        return np.ascontiguousarray(values, np.float32)
    rows = np.empty((order.shape[0], 3), np.float32)
    gather_xyz(values, order, rows)
    return rows


def cache_rows(solver, h: float | None) -> tuple[np.ndarray, np.ndarray | None]:
    """An integrator's ``cache_rows`` from its world_points and world_velocities (see
    clothtool.sim.integrators.Integrator)."""
    points = in_vertex_order(solver.model, solver.world_points())
    return points, None if h is None else in_vertex_order(solver.model, solver.world_velocities(h))
