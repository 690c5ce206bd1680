"""clothtool.solver.air.corner_shares: each particle's share in its triangles' air force
matches its lumped mass (closed forms on small meshes)."""

from __future__ import annotations

import dataclasses

import numpy as np

from clothtool.cook.cooker import CookOptions, cook_fabric
from clothtool.mesh.shapes import grid
from clothtool.settings import Material, Placement
from clothtool.solver.air import corner_shares
from clothtool.solver.model import build_model


def model_of(columns, rows, quads, units=1.0):
    mesh = grid(columns, rows, 0.1, quads=quads, plane="XZ")
    fabric = cook_fabric(mesh, CookOptions()).fabric
    return build_model("cloth", fabric, Material(areal_density=0.2), Placement(), units, "Y")


def test_a_triangle_mesh_gets_exactly_the_thirds():
    for units in (1.0, 0.01):
        assert np.all(corner_shares(model_of(5, 4, quads=False, units=units)) == 1.0)


def test_a_quad_grid_shares_follow_the_quarters_of_each_quad():
    """A quad gives each corner a quarter of its area as mass; its two triangles (split along
    one diagonal) cover the diagonal's corners twice. A grid's corner on the diagonal has the
    area of two triangles around it (one quad) for a quarter quad of mass: share 3/4; the
    other two corners one triangle (half a quad): 3/2. Interior particles: 6 triangles
    (3 quads) for 1 quad of mass: share 1."""
    model = model_of(4, 4, quads=True)
    share = corner_shares(model)
    pos = model.rest_pos
    corners = np.flatnonzero((np.isin(pos[:, 0], [pos[:, 0].min(), pos[:, 0].max()]))
                             & (np.isin(pos[:, 2], [pos[:, 2].min(), pos[:, 2].max()])))
    np.testing.assert_allclose(sorted(share[corners]), [0.75, 0.75, 1.5, 1.5], rtol=1e-6)
    inner = (pos[:, 0] > pos[:, 0].min()) & (pos[:, 0] < pos[:, 0].max()) & (pos[:, 2] > pos[:, 2].min()) & (pos[:, 2] < pos[:, 2].max())
    np.testing.assert_allclose(share[inner], 1.0, rtol=1e-6)


def test_a_uniform_pressure_gives_each_particle_its_own_areas_force():
    """sum over a particle's triangles of share * A_t / 3 = its lumped area, on any mesh."""
    for quads in (True, False):
        model = model_of(6, 5, quads=quads)
        share = corner_shares(model).astype(np.float64)
        tri = model.triangles
        p = model.rest_pos.astype(np.float64)
        area = 0.5 * np.linalg.norm(np.cross(p[tri[:, 1]] - p[tri[:, 0]], p[tri[:, 2]] - p[tri[:, 0]]), axis=1)
        force = np.zeros(model.particle_count)
        for corner in range(3):
            np.add.at(force, tri[:, corner], share[tri[:, corner]] * area / 3)
        np.testing.assert_allclose(force, model.mass / 0.2, rtol=1e-6)


def test_shares_are_the_bits_of_summing_each_corners_areas_in_turn():
    """The areas around each particle are summed corner by corner, triangle by triangle
    (as np.add.at adds them): the shares of a grid with a skewed corner are those bits."""
    model = model_of(6, 5, quads=True)
    pos = model.rest_pos.astype(np.float64)
    pos[7] += [0.013, 0.0, -0.021]  # triangles of unequal areas around one particle
    model = dataclasses.replace(model, rest_pos=pos.astype(model.rest_pos.dtype))
    pos = model.rest_pos.astype(np.float64)
    tri = model.triangles
    area = 0.5 * np.linalg.norm(np.cross(pos[tri[:, 1]] - pos[tri[:, 0]], pos[tri[:, 2]] - pos[tri[:, 0]]), axis=1)
    around = np.zeros(model.particle_count)
    for corner in range(3):
        np.add.at(around, tri[:, corner], area)
    lumped = model.mass / model.mass.sum()
    expected = np.divide(lumped * around.sum(), around, out=np.zeros_like(around), where=around > 0)
    expected[np.abs(expected - 1.0) < 1e-6] = 1.0
    assert corner_shares(model).tobytes() == expected.astype(np.float32).tobytes()
