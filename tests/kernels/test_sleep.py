"""max_displacement against tests/reference/sleep.py."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from clothtool.solver.kernels.sleep import max_displacement
from tests.kernels._data import U, particles
from tests.reference import sleep as ref


@settings(max_examples=30)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(0, 80))
def test_max_displacement_matches_reference(seed, n):
    cur, prev = particles(np.random.default_rng(seed), n)
    got = max_displacement(cur, prev)
    want = ref.max_displacement(cur, prev)
    assert abs(got - want) <= 4 * U * want + 1e-12


def test_max_displacement_is_infinite_when_a_position_is_not_finite():
    cur, prev = particles(np.random.default_rng(1), 10)
    for bad in (np.nan, np.inf):
        broken = cur.copy()
        broken[7, 1] = bad
        assert max_displacement(broken, prev) == np.inf == ref.max_displacement(broken, prev)
    assert max_displacement(cur[:0], prev[:0]) == 0.0 == ref.max_displacement(cur[:0], prev[:0])
