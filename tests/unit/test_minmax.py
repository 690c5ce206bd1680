"""clothtool._minmax: largest/smallest in a kernel give what Python's max/min give, bit for bit."""

from __future__ import annotations

import math

import numpy as np
import pytest

from clothtool._jit import kernel
from clothtool._minmax import largest, smallest


@kernel
def _pairs(a, b):
    return largest(a, b), smallest(a, b)


@kernel
def _triples(a, b, c):
    return largest(a, b, c), smallest(a, b, c)


@kernel
def _mixed(a, b):
    return largest(a, b), smallest(a, b), largest(b, 0), smallest(b, 0)


SPECIAL = [0.0, -0.0, 1.5, -2.25, math.inf, -math.inf, math.nan]


def _same(got, want) -> bool:
    """Equal bits (so NaN equals NaN and -0.0 differs from 0.0)."""
    return np.float64(got).tobytes() == np.float64(want).tobytes()


@pytest.mark.parametrize("a", SPECIAL)
@pytest.mark.parametrize("b", SPECIAL)
def test_two_floats_as_python(a, b):
    high, low = _pairs(a, b)
    assert _same(high, max(a, b)) and _same(low, min(a, b)), (a, b, high, low)


@pytest.mark.parametrize("values", [(1.0, math.nan, 0.5), (math.nan, 2.0, 3.0), (0.0, -0.0, 0.0), (3.0, 1.0, 2.0)])
def test_three_floats_as_python(values):
    high, low = _triples(*values)
    assert _same(high, max(values)) and _same(low, min(values)), (values, high, low)


def test_integers_stay_integers_and_float32_unifies_to_float64():
    assert _pairs(3, -7) == (3, -7)
    assert isinstance(_pairs(3, -7)[0], int)
    high, low, clamp_high, clamp_low = _mixed(np.float32(0.1), 4)
    assert high == 4.0 and low == float(np.float32(0.1)) and (clamp_high, clamp_low) == (4, 0)
