"""Frame functions call their kernels through a table of addresses (clothtool.solver.framecall):
the table compile_for makes runs the kernels, a table made for other argument types is
refused, and the callees' types are recorded beside the module for processes that load the
frame function from the disk cache."""

from __future__ import annotations

import numba
import numpy as np
import pytest

from clothtool._jit import KERNEL_OPTIONS
from clothtool.solver import framefn
from clothtool.solver.framefn import FusedCall, compile_for, compile_frame, frame_source
from clothtool.solver.kernels.rows import copy_xyz, xyz_velocity


def _frame_function():
    """A frame function of two stages: copy cur's xyz into ``out``, then the velocity from prev."""
    calls = [
        FusedCall(("{copy}(cur, {out})",), {"out": None}, {"copy": copy_xyz}),
        FusedCall(("{velocity}(cur, prev, {h}, {velocities})",), {"h": None, "velocities": None},
                  {"velocity": xyz_velocity}),
    ]
    source, _ = frame_source(calls)
    return source, compile_frame(source)


def _arguments(dtype):
    rng = np.random.default_rng(7)
    cur, prev = rng.random((5, 4)).astype(dtype), rng.random((5, 4)).astype(dtype)
    out, velocities = np.zeros((5, 3), dtype), np.zeros((5, 3), np.float32)
    return (1, cur, prev, out, dtype(0.5), velocities)


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_the_table_runs_each_kernel_as_a_call_from_python_does(dtype):
    source, function = _frame_function()
    assert "CALLEES = ('k0_copy', 'k1_velocity')" in source
    arguments = _arguments(dtype)
    table = compile_for(function, arguments)
    assert table.shape == (2, 2) and table.dtype == np.uint64 and np.all(table[:, 0] != 0)
    function(*arguments, table)
    _, cur, prev, out, h, velocities = arguments
    expected_out, expected_velocities = np.zeros_like(out), np.zeros_like(velocities)
    copy_xyz(cur, expected_out)
    xyz_velocity(cur, prev, h, expected_velocities)
    assert np.array_equal(out, expected_out) and np.array_equal(velocities, expected_velocities)


def test_a_table_for_other_types_raises_instead_of_calling():
    _, function = _frame_function()
    single, double = _arguments(np.float32), _arguments(np.float64)
    compile_for(function, single)
    table_for_double = compile_for(function, double)
    with pytest.raises(RuntimeError, match="callee table row 0 does not hold copy_xyz"):
        function(*single, table_for_double)


def test_the_frame_function_does_not_compile_outside_compile_for():
    _, function = _frame_function()
    arguments = _arguments(np.float32)
    table = compile_for(function, arguments)
    ints = (1, *(a.astype(np.int64) for a in arguments[1:4]), np.int64(1), arguments[5])
    with pytest.raises(TypeError):
        function(*ints, table)


def test_a_process_that_loads_the_function_finds_the_callee_types_recorded(tmp_path, monkeypatch):
    source, function = _frame_function()
    path = framefn._record_path(function)
    if path is None:
        pytest.skip("no usable kernel cache directory: frame functions compile in memory")
    arguments = _arguments(np.float32)
    table = compile_for(function, arguments)
    record = framefn._read_record(path)
    types = next(key for key in record if "float32" in key)
    assert [len(args) for args in record[types]] == [2, 4]
    # as a later process does: the function loaded (here: already compiled), callee types
    # from the record, not from typing
    monkeypatch.setattr(framefn, "_TABLES", {})
    monkeypatch.setattr(framefn, "TYPED_SLOTS", {})
    assert np.array_equal(compile_for(function, arguments), table)


def _sum_rows(rows, out):
    """out[i] = the sum of row i's xyz, through an array it allocates."""
    scratch = np.empty(rows.shape[0])
    for i in range(rows.shape[0]):
        scratch[i] = rows[i, 0] + rows[i, 1] + rows[i, 2]
    for i in range(rows.shape[0]):
        out[i] = scratch[i]


# no disk cache: compiled in this process, the first time a frame function's typing asks for it
sum_rows = numba.njit(**KERNEL_OPTIONS)(_sum_rows)


def test_a_kernel_first_compiled_for_a_frame_function_keeps_reference_counting():
    """Frame functions compile without reference counting; a kernel compiled while one is
    typed must not inherit that (numba's default): this one allocates, which needs it."""
    source, _ = frame_source([FusedCall(("{sum_rows}(cur, {out})",), {"out": None}, {"sum_rows": sum_rows})])
    function = compile_frame(source)
    cur = np.arange(12, dtype=np.float64).reshape(3, 4)
    out = np.zeros(3)
    arguments = (1, cur, cur, out)
    assert not sum_rows.overloads
    table = compile_for(function, arguments)
    function(*arguments, table)
    assert out.tolist() == [3.0, 15.0, 27.0]
