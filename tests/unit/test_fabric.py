"""Fabric.validate catches each kind of corruption, naming the field."""

from __future__ import annotations

import numpy as np
import pytest

from clothtool.cook.cooker import CookOptions, cook_fabric
from clothtool.errors import FabricError
from clothtool.mesh.shapes import grid


@pytest.fixture(scope="module")
def fabric():
    return cook_fabric(
        grid(5, 4, 0.1), CookOptions(pin_box=(-1, -0.01, -1, 1, 1, 1), virtual_particles=4)
    ).fabric


def test_cooked_fabric_is_valid(fabric):
    fabric.validate()
    assert fabric.particle_count == 20
    assert fabric.pinned.sum() == 5
    assert fabric.tethers_per_particle == 1


def corrupt(fabric, name, change):
    array = getattr(fabric, name).copy()
    change(array)
    return fabric.replace(**{name: array})


@pytest.mark.parametrize(
    "name, change, pattern",
    [
        ("rest_pos", lambda a: a.__setitem__((3, 1), np.nan), "rest_pos.*row 3 is NaN"),
        ("particle_inv_mass", lambda a: a.__setitem__(2, -1.0), "negative"),
        ("constraint_indices", lambda a: a.__setitem__((4, 1), 99), r"row 4 holds \[.*99\]"),
        ("triangles", lambda a: a.__setitem__((0, 0), -1), "triangles.*row 0"),
        ("set_offsets", lambda a: a.__setitem__(1, a[2] + 1), "set_offsets.*decreases"),
        ("constraint_stiffness", lambda a: a.__setitem__(0, 1.5), r"\[0, 1\]"),
        ("constraint_rest_length", lambda a: a.__setitem__(0, -0.1), "negative lengths"),
        ("phase_type", lambda a: a.__setitem__(0, 9), "unknown type 9"),
        ("virtual_particles", lambda a: a.__setitem__((0, 3), 7), "virtual_particles"),
        ("tether_rest_length", lambda a: a.__setitem__(1, -0.2), r"tether_rest_length.*negative lengths \(entry 1 is -0.2\)"),
        ("particle_max_distance", lambda a: a.__setitem__(4, -1.0), "particle_max_distance.*negative distances"),
        ("particle_area", lambda a: a.__setitem__(0, -1e-3), "particle_area.*negative areas"),
    ],
)
def test_validate_names_the_broken_field(fabric, name, change, pattern):
    with pytest.raises(FabricError, match=pattern):
        corrupt(fabric, name, change).validate()


def test_validate_catches_a_conflict_inside_a_set(fabric):
    pairs = fabric.constraint_indices.copy()
    first = slice(fabric.set_offsets[0], fabric.set_offsets[1])
    movable = np.flatnonzero(fabric.particle_inv_mass > 0)
    pairs[first][0] = [movable[0], movable[1]]
    pairs[first][1] = [movable[0], movable[2]]
    with pytest.raises(FabricError, match=r"set 0 uses movable particle \d+ twice"):
        fabric.replace(constraint_indices=pairs).validate()


def test_validate_catches_a_tether_to_a_free_particle(fabric):
    anchors = fabric.tether_anchor.copy()
    free = np.flatnonzero(fabric.particle_inv_mass > 0)
    anchors[free[0]] = free[1]
    with pytest.raises(FabricError, match="anchors to a movable particle"):
        fabric.replace(tether_anchor=anchors).validate()


def test_validate_checks_dtypes(fabric):
    with pytest.raises(FabricError, match="rest_pos.*dtype float64"):
        fabric.replace(rest_pos=fabric.rest_pos.astype(np.float64)).validate()


def test_max_distance_may_be_infinite_but_not_nan(fabric):
    assert np.isinf(fabric.particle_max_distance).all()
    with pytest.raises(FabricError, match="particle_max_distance"):
        corrupt(fabric, "particle_max_distance", lambda a: a.__setitem__(0, np.nan)).validate()


@pytest.mark.parametrize("quads", [False, True])
def test_lumped_areas_sum_to_the_cloth_area_and_are_uniform_inside(quads):
    h = 0.1
    fabric = cook_fabric(grid(6, 5, h, quads=quads), CookOptions()).fabric
    np.testing.assert_allclose(fabric.particle_area.sum(), 5 * h * 4 * h, rtol=1e-5)
    interior = fabric.in_vertex_order(fabric.particle_area).reshape(5, 6)[1:-1, 1:-1]
    if quads:  # with triangles the lumping depends on the diagonal direction
        np.testing.assert_allclose(interior, h * h, rtol=1e-5)
    np.testing.assert_allclose(fabric.particle_inv_mass, 1.0 / fabric.particle_area, rtol=1e-6)


@pytest.mark.parametrize(
    "hang, pattern",
    [
        (np.array([0, np.nan, 0], np.float32), "hang_direction.*NaN"),
        (np.zeros(7, np.float32), r"hang_direction.*shape \(7,\)"),
        (np.array([0, -2, 0], np.float32), "hang_direction.*length 2"),
    ],
)
def test_validate_checks_the_hang_direction(fabric, hang, pattern):
    with pytest.raises(FabricError, match=pattern):
        fabric.replace(hang_direction=hang).validate()


@pytest.mark.parametrize("mpu", [0.0, -1.0, np.inf, np.nan])
def test_validate_checks_meters_per_unit(fabric, mpu):
    with pytest.raises(FabricError, match="meters_per_unit.*positive finite"):
        fabric.replace(meters_per_unit=mpu).validate()


def test_validate_limits_virtual_batches_to_four(fabric):
    v = fabric.virtual_particles.shape[0]
    offsets = np.array([0, 5, *range(6, v + 1)], np.int32)  # the first batch holds 5
    with pytest.raises(FabricError, match="batch 0 holds 5 virtual particles; at most 4"):
        fabric.replace(virtual_batch_offsets=offsets).validate()


def test_validate_refuses_a_virtual_batch_sharing_a_movable_particle(fabric):
    movable = np.flatnonzero(fabric.particle_inv_mass > 0)
    rows = fabric.virtual_particles.copy()
    batch = slice(fabric.virtual_batch_offsets[1], fabric.virtual_batch_offsets[2])
    assert batch.stop - batch.start >= 2
    rows[batch.start, :3] = movable[:3]
    rows[batch.start + 1, :3] = [movable[2], movable[3], movable[4]]
    with pytest.raises(FabricError, match=f"batch 1 uses movable particle {movable[2]} twice"):
        fabric.replace(virtual_particles=rows).validate()


def test_cooked_virtual_batches_pass(fabric):
    sizes = np.diff(fabric.virtual_batch_offsets)
    assert sizes.size and sizes.max() <= 4
    fabric.validate()
