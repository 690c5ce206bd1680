"""clothtool._jit's device helpers: kernels call a twin compiled without the CPython wrapper;
a call from Python compiles the helper itself, with the same results."""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pytest
from numba.core.caching import NullCache
from numba.core.dispatcher import Dispatcher

from clothtool._jit import DeviceKernel, kernel

pytestmark = pytest.mark.skipif(not isinstance(kernel(lambda: None), Dispatcher), reason="NUMBA_DISABLE_JIT=1")


@kernel(device=True)
def _scaled_sum(values, scale):
    total = 0.0
    for v in values:
        total += v * scale
    return total


@kernel(inline="always")
def _square(x):
    return x * x


@kernel(device=True)
def _weighted_sum(values, weight):  # called from Python only (test_a_call_from_python...)
    total = 0.0
    for v in values:
        total += v * weight
    return total


@kernel
def _uses_helpers(values, scale):
    return _square(_scaled_sum(values, scale))


def _compiled_here(*kernels):
    """Kernels compiled in this process, never loaded from the kernel cache: one loaded from
    it needs no twin (its code holds the helpers), so a warm cache would hide the twins."""
    for k in kernels:
        k._cache = NullCache()


def test_kernels_compile_and_link_the_wrapperless_twin_only():
    _compiled_here(_uses_helpers)
    values = np.array([1.0, 2.0, 3.5])
    assert _uses_helpers(values, 2.0) == (13.0) ** 2
    for helper in (_scaled_sum, _square):
        assert isinstance(helper, DeviceKernel)
        assert helper.twin.targetoptions["no_cpython_wrapper"] is True
        assert helper.twin.signatures, "the caller compiled the twin"
        assert not helper.signatures, "the helper itself compiles only when Python calls it"


def test_a_call_from_python_compiles_the_helper_itself_with_the_same_result():
    values = np.array([0.25, -4.0, 9.0], np.float32)
    expected = float(np.sum(values.astype(np.float64) * 3.0))
    assert _weighted_sum(values, 3.0) == expected
    assert _weighted_sum.signatures and not _weighted_sum.twin.signatures


def test_plain_kernels_are_not_device_kernels():
    assert not isinstance(_uses_helpers, DeviceKernel)


@kernel(device=True)
def _column_sum(rows, column, flag):
    total = 0.0
    for r in range(rows.shape[0]):
        total += rows[r, column]
    return -total if flag else total


@kernel
def _constant_and_loop_columns(rows):
    """Calls the helper with constant columns (integer literals) and with a loop variable
    whose first value is a constant; a boolean literal stays literal."""
    total = _column_sum(rows, 0, False) + _column_sum(rows, 1, False) + _column_sum(rows, (0, 1)[1], False)
    column = 0
    while column < rows.shape[1]:
        total += _column_sum(rows, column, False)
        column += 1
    return total


def test_a_device_kernel_compiles_once_for_all_integer_constants():
    _compiled_here(_constant_and_loop_columns)
    rows = np.arange(6.0).reshape(3, 2)  # columns sum to 6 and 9
    assert _constant_and_loop_columns(rows) == 6.0 + 9.0 + 9.0 + 6.0 + 9.0
    signatures = _column_sum.twin.signatures
    assert len(signatures) == 1, signatures
    _, column, flag = signatures[0]
    assert str(column) == "int64" and str(flag) == "Literal[bool](False)"


def test_kernels_have_no_c_function_wrapper():
    assert _uses_helpers.targetoptions["no_cfunc_wrapper"] is True


def test_numba_error_messages_are_not_highlighted():
    """clothtool sets this before numba loads (in a fresh process, which imports a kernel
    module): numba's highlighting formats every exception it raises and catches while
    compiling through colorama (~0.4 s of a cold walk bake)."""
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_DISABLE_ERROR_MESSAGE_HIGHLIGHTING"}
    probe = ("import clothtool.solver.kernels.collide\n"
             "from numba.core import errors\n"
             "print(type(errors.termcolor()).__name__)")
    result = subprocess.run([sys.executable, "-c", probe], env=env, capture_output=True, text=True, check=True)
    assert result.stdout.strip() == "NOPColorScheme"
