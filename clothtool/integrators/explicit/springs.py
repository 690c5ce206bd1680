"""Spring and air parameters of the mass-spring model, from the material's physical values.

Units. Positions are in scene units (s metres per unit), masses in kg, time in s. Newton's law
in scene units reads m a_s = F / s, so a force expressed in kg * scene units / s^2 is the
force in newtons divided by s. Then:

* a spring of stiffness k (N/m) stretched by C_s scene units pulls with k C_s s N, i.e.
  k C_s in scene force units: **the spring constant is the same number in every unit
  system** (a hanging mass sags m g / k metres = m g_s / k scene units, g_s = g / s);
* a damper of coefficient c (N s/m = kg/s) is likewise the same number;
* a drag per unit area and unit normal speed c_w (kg/(m^2 s)) acting on A_s scene units^2
  at v_s scene units/s gives c_w (A_s s^2)(v_s s) N, i.e. (c_w s^2) A_s v_s in scene units.

``clothtool.solver.fabric.constraint_compliance`` holds the modulus -> stiffness mapping
shared with the XPBD mode; it returns 1 / k.
"""

from __future__ import annotations

import numpy as np

from clothtool.solver.fabric import constraint_compliance


def spring_stiffness(model) -> np.ndarray:
    """f64 (c,) spring constant of each constraint in N/m (= kg/s^2, also in scene units).

    Stretch (vertical, horizontal) and shear springs of rest length L between particles of
    lumped areas a, b: k = modulus * A / L^2 with A = (a + b) / 2; bend springs:
    k = bend_modulus * A / L^4; painted per-constraint stiffness scales k (the mapping of
    ``constraint_compliance``).
    """
    compliance = constraint_compliance(model)
    with np.errstate(divide="ignore"):
        return np.where(np.isfinite(compliance) & (compliance > 0), 1.0 / compliance, 0.0)


def spring_damping(model, stiffness: np.ndarray) -> np.ndarray:
    """f64 (c,) damping coefficient of each spring in kg/s (the same in scene units).

    A spring between masses m_a, m_b oscillates (along itself) like one mass
    m_eff = m_a m_b / (m_a + m_b) = 1 / (w_a + w_b) on a spring k (w = inverse mass, 0 when
    pinned, so m_eff is the free mass when the other end is pinned). The damper
    c = 2 zeta sqrt(k m_eff) gives that oscillator the damping ratio zeta = Material.damping
    (0 = undamped, 1 = critically damped). A spring between two pinned particles gets 0.
    """
    pairs = model.constraint_indices
    w = model.inv_mass.astype(np.float64)
    w_sum = w[pairs[:, 0]] + w[pairs[:, 1]] if pairs.shape[0] else np.zeros(0)
    zeta = float(model.material.damping)
    with np.errstate(divide="ignore", invalid="ignore"):
        m_eff = np.where(w_sum > 0, 1.0 / np.where(w_sum > 0, w_sum, 1.0), 0.0)
    return 2.0 * zeta * np.sqrt(stiffness * m_eff)


def air_density(model, fluid_density: float) -> float:
    """The air law's coefficient rho s^3 / 12 (``kernels.explicit_wind``): with it the force on
    each corner of a triangle is in kg scene-units/s^2 for lengths in scene units."""
    return float(fluid_density) * model.units_to_meters**3 / 12.0


def air_damping(model, fluid_density: float, speed: float) -> float:
    """Drag per unit area and unit normal speed of the quadratic law linearised at the relative
    speed ``speed`` (scene units/s), scene units: d/du of 1/2 rho C_d s^3 |u| u for a face
    moving along its normal, rho C_d s^3 speed."""
    return float(fluid_density) * float(model.material.drag_coefficient) * model.units_to_meters**3 * float(speed)


def triangle_areas(pos: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """f64 (t,) triangle areas of ``pos`` (scene units^2)."""
    p = pos.astype(np.float64)
    e1 = p[triangles[:, 1]] - p[triangles[:, 0]]
    e2 = p[triangles[:, 2]] - p[triangles[:, 0]]
    return 0.5 * np.linalg.norm(np.cross(e1, e2), axis=1)
