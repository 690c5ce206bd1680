"""ClothState's particle rows start on a cache line (clothtool.solver.cloth.empty_rows), so
no 32-byte float64 row straddles two cache lines, and hold the rest pose and inverse masses."""

from __future__ import annotations

import numpy as np
import pytest

from clothtool.cook.cooker import CookOptions, cook_fabric
from clothtool.mesh.shapes import grid
from clothtool.settings import Material, Placement
from clothtool.solver.cloth import ROW_ALIGNMENT, ClothState, empty_rows
from clothtool.solver.model import build_model


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("count", [1, 5, 1000, 70000])
def test_empty_rows_start_on_a_cache_line(count, dtype):
    rows = empty_rows(count, dtype)
    assert rows.shape == (count, 4) and rows.dtype == dtype
    assert rows.flags.c_contiguous and rows.flags.writeable
    assert rows.ctypes.data % ROW_ALIGNMENT == 0
    rows[:] = np.arange(count * 4).reshape(count, 4)  # every byte is its own: no overlap with a neighbour
    assert rows[-1, 3] == count * 4 - 1


def test_empty_rows_are_separate_arrays():
    a, b = empty_rows(100, np.float64), empty_rows(100, np.float64)
    a[:] = 1.0
    b[:] = 2.0
    assert np.all(a == 1.0)


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_state_at_rest_is_aligned_and_holds_the_rest_pose(dtype):
    fabric = cook_fabric(grid(70, 70, 0.01), CookOptions(pin_box=(-1.0, -1e-4, -1.0, 1.0, 1.0, 1.0))).fabric
    model = build_model("sheet", fabric, Material(), Placement(), 1.0, "Y")
    state = ClothState.at_rest(model, dtype)
    for rows in (state.cur, state.prev):
        assert rows.dtype == dtype and rows.ctypes.data % ROW_ALIGNMENT == 0
        np.testing.assert_array_equal(rows[:, :3], model.rest_pos.astype(dtype))
        np.testing.assert_array_equal(rows[:, 3], model.inv_mass.astype(dtype))
    assert not np.shares_memory(state.cur, state.prev)
