"""clothtool._jit's device helpers: kernels call a twin compiled without the CPython wrapper;
a call from Python compiles the helper itself, with the same results."""

from __future__ import annotations

import numpy as np
import pytest
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


def test_kernels_compile_and_link_the_wrapperless_twin_only():
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
