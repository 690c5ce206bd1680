"""triangle_air (the air law every integrator uses) against tests/reference/air.py and the
textbook: face-on drag 1/2 rho C_d A |u|^2 against the motion, lift at right angles to the
motion peaking at 45 degrees, nothing without area or motion, no speed threshold."""

from __future__ import annotations

import math

import numpy as np
import pytest

from clothtool.solver.kernels.air import triangle_air
from tests.reference import air as ref


@pytest.mark.parametrize("seed", range(3))
def test_matches_reference(seed):
    rng = np.random.default_rng(seed)
    for _ in range(200):
        u = rng.normal(0.0, 2.0, 3) * 10.0 ** rng.uniform(-6, 1)
        m = rng.normal(0.0, 0.1, 3)
        drag, lift = rng.uniform(0, 1, 2)
        got = triangle_air(*u, *m, drag, lift)
        want = ref.triangle_air(*u, *m, drag, lift)
        assert got[3] and want[3]
        np.testing.assert_allclose(got[:3], want[:3], rtol=1e-10, atol=1e-14 * np.linalg.norm(want[:3]))


def test_face_on_drag_is_the_textbook_force():
    """u along the normal: G = |m| C_d |u| u (so F = -rho/4 G = -1/2 rho C_d A |u| u), no lift."""
    m = np.array([0.0, 0.3, 0.0])  # A = 0.15
    for speed in (1e-4, 1.0, 30.0):
        g = np.array(triangle_air(0.0, -speed, 0.0, *m, 0.8, 0.5)[:3])
        np.testing.assert_allclose(g, [0.0, -0.3 * 0.8 * speed * speed, 0.0], rtol=1e-12)


def test_edge_on_motion_feels_nothing_and_lift_peaks_at_45_degrees():
    m = np.array([0.0, 0.0, 2.0])  # unit normal z
    assert np.allclose(triangle_air(1.0, 0.0, 0.0, *m, 0.8, 0.5)[:3], 0.0)
    lifts = []
    for degrees in range(0, 91, 5):
        theta = math.radians(degrees)  # angle between u and the normal
        u = np.array([math.sin(theta), 0.0, math.cos(theta)])
        g = np.array(triangle_air(*u, *m, 0.0, 1.0)[:3])
        assert abs(g @ u) < 1e-12  # lift at right angles to the motion
        np.testing.assert_allclose(np.linalg.norm(g), 2.0 * math.cos(theta) * math.sin(theta), atol=1e-12)
        lifts.append(np.linalg.norm(g))
    assert int(np.argmax(lifts)) * 5 == 45


def test_no_area_or_no_motion_gives_no_force():
    assert not triangle_air(0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.8, 0.5)[3]
    assert not triangle_air(1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.8, 0.5)[3]
    assert not ref.triangle_air(1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.8, 0.5)[3]
