"""Random kernel inputs (seeded numpy Generators) and the float32-vs-float64 comparison."""

from __future__ import annotations

import numpy as np

F32 = np.float32
# float32 unit roundoff: one correctly rounded operation is off by at most U * |result|
U = float(np.finfo(np.float32).eps) / 2


def f32(x) -> np.ndarray:
    return np.ascontiguousarray(x, np.float32)


def particles(rng: np.random.Generator, n: int, pinned: float = 0.2, extent: float = 1.0, speed: float = 0.02):
    """(cur, prev) float32 (n,4): positions in [-extent, extent]^3, cur = prev + a step of
    about ``speed``, inverse masses in [0.5, 2] (w = 0 for a ``pinned`` fraction) in both."""
    prev = np.empty((n, 4), np.float32)
    prev[:, :3] = rng.uniform(-extent, extent, (n, 3))
    prev[:, 3] = np.where(rng.random(n) < pinned, 0.0, rng.uniform(0.5, 2.0, n))
    cur = prev.copy()
    cur[:, :3] += rng.normal(0.0, speed, (n, 3)).astype(np.float32)
    return cur, prev


def assert_close(actual, expected, atol, what: str = "") -> None:
    """Elementwise |actual - expected| <= atol (a scalar or an array that broadcasts), with the
    worst offender in the message. Non-finite values must match exactly.

    Kernels compute in float32 and references in float64, so each test states its ``atol``
    from the float32 rounding of the values involved (roughly ops * U * magnitude) with a
    margin; kernel bugs show up as errors of the size of the corrections themselves.
    """
    actual = np.asarray(actual, np.float64)
    expected = np.asarray(expected, np.float64)
    assert actual.shape == expected.shape, (what, actual.shape, expected.shape)
    same = (actual == expected) | (np.isnan(actual) & np.isnan(expected))
    err = np.where(same, 0.0, np.abs(actual - expected))
    err = np.where(np.isnan(err), np.inf, err)
    excess = err / np.broadcast_to(np.asarray(atol, np.float64), err.shape)
    if err.size and np.any(err > atol):
        worst = np.unravel_index(np.argmax(excess), err.shape)
        raise AssertionError(
            f"{what}: error {err[worst]:.3g} > tolerance at {worst}: kernel {actual[worst]!r}, "
            f"reference {expected[worst]!r} (max error {err.max():.3g})"
        )
