"""clothtool.solver.facepoints._circumradius: closed forms, and the bits of the plain numpy
formulation (np.linalg.norm over np.cross), which decides the same faces."""

from __future__ import annotations

import numpy as np

from clothtool.solver.facepoints import _circumradius


def _reference(corners: np.ndarray) -> np.ndarray:
    a = np.linalg.norm(corners[:, 1] - corners[:, 2], axis=-1)
    b = np.linalg.norm(corners[:, 2] - corners[:, 0], axis=-1)
    c = np.linalg.norm(corners[:, 0] - corners[:, 1], axis=-1)
    twice_area = np.linalg.norm(np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]), axis=-1)
    return np.where(twice_area > 0, a * b * c / np.maximum(2.0 * twice_area, 1e-300), np.maximum(np.maximum(a, b), c))


def test_closed_forms():
    right = [[0.0, 0.0, 0.0], [3.0, 0.0, 0.0], [0.0, 4.0, 0.0]]  # a right triangle: half its hypotenuse
    equilateral = [[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [1.0, np.sqrt(3.0), 0.0]]  # side / sqrt(3)
    line = [[0.0, 0.0, 0.0], [1.0, 1.0, 1.0], [2.0, 2.0, 2.0]]  # degenerate: its longest edge
    radii = _circumradius(np.array([right, equilateral, line]))
    np.testing.assert_allclose(radii, [2.5, 2.0 / np.sqrt(3.0), 2.0 * np.sqrt(3.0)], rtol=1e-12)


def test_the_bits_of_norms_over_cross_products():
    rng = np.random.default_rng(5)
    corners = rng.normal(size=(20000, 3, 3)) * 10.0 ** rng.uniform(-4, 4, (20000, 1, 1))
    corners[:50, 2] = corners[:50, 0]  # degenerate ones
    assert _circumradius(corners).tobytes() == _reference(corners).tobytes()
