"""A hanging chain settles into the discrete catenary.

N equal point masses m on N + 1 inextensible links of length L between two pinned ends at the
same height, a span D apart. At rest the horizontal tension H is the same in every link and
each mass adds m g to the vertical one, so the slopes are s_k = (m g / H) (k - N / 2),
k = 0..N, and H is fixed by the span: sum_k L / sqrt(1 + s_k^2) = D (solved with scipy's
brentq, in float64). The sag is the depth of the lowest node.

The solver uses stiffness 1 at a stiffness frequency equal to its own frequency, so every link
is projected exactly once per iteration; position-based dynamics then still leaves the links
stretched by O(g h^2 N^2) at rest (0.04 % at 1200 Hz, 0.17 % at 600 Hz), which deepens the
sag by 0.1 mm at 1200 Hz and 0.4 mm at 600 Hz, against a tolerance of 1e-3 of the chain's
length (1.1 mm); the last test checks that this error shrinks as h^2.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import brentq

from clothtool.settings import Material, PhaseSettings, SolverConfig

G = 9.81


def discrete_catenary(n: int, link: float, span: float) -> np.ndarray:
    """(n+2, 2) node positions (x, y) of the hanging chain, ends at (0, 0) and (span, 0)."""
    k = np.arange(n + 1) - n / 2.0

    def span_error(c):  # c = m g / H
        return float(np.sum(link / np.sqrt(1.0 + (c * k) ** 2))) - span

    c = brentq(span_error, 1e-12, 1e6, xtol=1e-15, rtol=1e-15)
    slope = c * k
    dx = link / np.sqrt(1.0 + slope**2)
    dy = link * slope / np.sqrt(1.0 + slope**2)
    return np.column_stack([np.concatenate([[0.0], np.cumsum(dx)]), np.concatenate([[0.0], np.cumsum(dy)])])


def u_shaped_chain(n: int, link: float, down: int) -> np.ndarray:
    """Start pose: down ``down`` links, across, and up again (all links of length ``link``);
    far from the catenary (it is square-bottomed and not as deep)."""
    across = n + 1 - 2 * down
    steps = [(0.0, -link)] * down + [(link, 0.0)] * across + [(0.0, link)] * down
    xy = np.vstack([[0.0, 0.0], np.cumsum(steps, axis=0)])
    return np.column_stack([xy, np.zeros(n + 2)])


def hang_chain(masses: int, down: int, frequency: float, precision: str, build_fabric, solver_for):
    """Hang the chain for 4 s at 50 fps; returns (rest pose, final points, speed over the last
    frame in m/s), positions in float64."""
    link = 0.1
    rest = u_shaped_chain(masses, link, down)
    inv_mass = np.ones(masses + 2)
    inv_mass[[0, -1]] = 0.0
    links = np.column_stack([np.arange(masses + 1), np.arange(1, masses + 2)])
    fabric = build_fabric(rest, inv_mass, [links[0::2], links[1::2]])  # two conflict-free sets
    # velocity decays as exp(-20 t): damping d per stiffness-frequency step, (1-d)^f = e^-20
    material = Material(
        areal_density=1.0, damping=1.0 - math.exp(-20.0 / frequency), vertical=PhaseSettings(stiffness=1.0)
    )
    config = SolverConfig(frequency=frequency, stiffness_frequency=frequency, precision=precision)
    solver = solver_for(fabric, material, config, gravity=(0.0, -G, 0.0))
    fps = 50
    dt = 1.0 / fps
    for frame in range(1, 4 * fps + 1):
        before = solver.world_points().astype(np.float64)
        solver.step(frame, (frame - 1) * dt, dt)
    points = solver.world_points().astype(np.float64)
    return rest, points, np.linalg.norm(points - before, axis=1).max() / dt


# float32 rounding keeps the stiff chain jittering at ~0.5 mm/s (1200 Hz); float64 settles to 1e-12
STILL = {"float32": 2e-3, "float64": 1e-6}


@pytest.mark.parametrize("precision", ["float32", "float64"])
@pytest.mark.parametrize("masses, down, frequency", [(10, 3, 1200), (7, 2, 1200), (10, 3, 600)])
def test_hanging_chain_matches_discrete_catenary(masses, down, frequency, precision, build_fabric, solver_for):
    link = 0.1
    rest, points, speed = hang_chain(masses, down, frequency, precision, build_fabric, solver_for)
    assert speed < STILL[precision], f"the chain still moves at {speed:.3g} m/s after 4 s"
    assert np.abs(points[:, 2]).max() < 1e-6  # stays in its plane

    exact = discrete_catenary(masses, link, rest[-1, 0])
    length = (masses + 1) * link
    sag, exact_sag = -points[:, 1].min(), -exact[:, 1].min()
    assert abs(sag - exact_sag) < 1e-3 * length, (
        f"sag {sag:.5f} m, discrete catenary {exact_sag:.5f} m (chain {length:.2f} m, span {rest[-1, 0]:.2f} m)"
    )
    node_error = np.abs(points[:, :2] - exact).max()
    assert node_error < 1e-3 * length, f"a node is {node_error:.3g} m from the catenary"
    # nearly inextensible: every link within 0.2 % of L
    stretch = np.abs(np.linalg.norm(np.diff(points, axis=0), axis=1) / link - 1.0).max()
    assert stretch < 2e-3, f"links stretched by {stretch:.3%}"
    # and the start pose was not already the answer
    assert abs(-rest[:, 1].min() - exact_sag) > 0.05


def test_hanging_chain_converges_to_catenary_as_h_squared(build_fabric, solver_for):
    """The stretch PBD leaves at rest is O(g h^2): doubling the frequency quarters the distance
    to the inextensible catenary (float64 state, so that rounding does not blur it)."""
    errors = {}
    for frequency in (600, 1200, 2400):
        rest, points, speed = hang_chain(10, 3, frequency, "float64", build_fabric, solver_for)
        assert speed < STILL["float64"]
        errors[frequency] = np.abs(points[:, :2] - discrete_catenary(10, 0.1, rest[-1, 0])).max()
    for low, high in ((600, 1200), (1200, 2400)):
        ratio = errors[low] / errors[high]
        assert 3.0 < ratio < 5.0, f"error {errors[low]:.3g} m at {low} Hz, {errors[high]:.3g} m at {high} Hz"
