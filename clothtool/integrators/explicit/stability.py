"""The largest stable substep of symplectic Euler on a cloth's springs (and air drag).

One spring. Two particles of masses m_a, m_b joined by a spring k with damper c: along the
spring their separation x obeys x'' = -omega^2 x - gamma x' with

    omega^2 = k (1/m_a + 1/m_b),      gamma = c (1/m_a + 1/m_b)

(1/m = 0 for a pinned end). Symplectic Euler with forces from the start of the step,
v' = v + h (-omega^2 x - gamma v), x' = x + h v', is the linear map

    [x']   [1 - h^2 omega^2   h (1 - h gamma)] [x]
    [v'] = [   -h omega^2        1 - h gamma ] [v]

with determinant 1 - h gamma and trace 2 - h^2 omega^2 - h gamma. Both eigenvalues lie in the
unit disc (Jury) iff |det| < 1 and |trace| < 1 + det, that is h gamma < 2 and

    h^2 omega^2 + 2 h gamma < 4      <=>      h < h_max = 4 / (gamma + sqrt(gamma^2 + 4 omega^2))

Undamped, h_max = 2 / omega = 2 sqrt(m_eff / k). With c = 2 zeta sqrt(k m_eff) (gamma =
2 zeta omega, see ``springs.spring_damping``) h_max = (2 / omega) (sqrt(1 + zeta^2) - zeta):
damping *lowers* the limit (0.90x at zeta = 0.1, 0.62x at 0.5, 0.41x at 1).

The whole cloth. A particle shares several springs, so the cloth's fastest mode is faster
than any one spring's: a chain of equal masses m and springs k zig-zags at omega^2 = 4 k / m,
twice the 2 k / m of one free spring, and a sheet's limit is about 1/sqrt(2) of its stiffest
spring's. The per-mode condition above holds for the whole cloth with omega^2 and gamma
replaced by the largest eigenvalues of M^-1 K and M^-1 C (exact when damping is proportional
to stiffness, as along a uniform chain). Both are bounded with Irons' element eigenvalue
theorem: split each particle's mass among its elements along their directions,
M_i = sum_e mu_ie P_e + (rest), with

    mu_ie = m_i s_e / lambda_i,     lambda_i = largest eigenvalue of sum_{e at i} s_e P_e (3x3)

(s_e = k_e and P_e = d d^T for a spring along d; for C also the wind stage's drag, s_t =
c_w A_t / 9 and P_t = n n^T per triangle, whose corners feel -(c_w A_t / 3) n n^T of its
mean velocity, with c_w the quadratic drag linearised at the wind's speed); each element's own eigenvalue is then sum_{j in e} lambda_j / m_j, and

    Lambda = max over elements e of sum_{free j in e} lambda_j / m_j  >=  the cloth's eigenvalue

It is exact for one spring (pinned or free) and for a chain's zig-zag, and on a regular grid
only the shear and bend springs' share above the stretch springs' (about 5% in omega^2 for
cotton). h_max = 4 / (Gamma + sqrt(Gamma^2 + 4 Lambda_K)).

The directions are the rest pose's: the bound is for the rest state. A deformed cloth's
springs turn, and a stretched spring adds transverse stiffness k (1 - L/l); the bake's
NaN / max-speed check catches what that costs. ``any_configuration`` gives the bound that
holds in every configuration (block Gershgorin, direction-free: row sums of
k_ij (1/m_i + 1/sqrt(m_i m_j))), about 1.4x (2x in omega^2) below the rest-state figure on a
sheet. The drag's dependence on the normal's rotation and on the cloth's own speed through
the air are left out (of order rho C_d |u| / areal density, tens per second at a few metres
per second, far below the springs' damping rates).
"""

from __future__ import annotations

import math

import numpy as np

from clothtool.integrators.explicit.springs import air_damping, spring_damping, spring_stiffness, triangle_areas

# A substep longer than FACTOR * h_max is refused (without --force): the bound is an upper
# bound of the rest state's fastest mode, so 1.0 lets no setting through that is unstable at rest.
FACTOR = 1.0


def step_limit(lambda_k: float, gamma: float) -> float:
    """h_max = 4 / (Gamma + sqrt(Gamma^2 + 4 Lambda_K)) in seconds (inf with no springs)."""
    denominator = gamma + math.sqrt(gamma * gamma + 4.0 * lambda_k)
    return math.inf if denominator == 0.0 else 4.0 / denominator


def drag_coefficient(model, environment) -> float:
    """The wind stage's drag per unit area in scene units, linearised at the wind's speed at
    the start (0 in still air or when the stage does not run; module docstring)."""
    if environment is None or not model.material.drag_coefficient > 0:
        return 0.0
    speed = float(np.linalg.norm(environment.wind_at(0.0))) / model.units_to_meters
    return air_damping(model, getattr(environment, "fluid_density", 1.0), speed)


def _spring_directions(model) -> tuple[np.ndarray, np.ndarray]:
    """Unit rest directions (c,3) of the springs and a mask of zero-length ones."""
    pos = model.rest_pos.astype(np.float64)
    pairs = model.constraint_indices
    d = pos[pairs[:, 1]] - pos[pairs[:, 0]]
    length = np.linalg.norm(d, axis=1)
    degenerate = ~(length > 0)
    return d / np.where(degenerate, 1.0, length)[:, None], degenerate


def element_bound(model, spring_weight: np.ndarray, drag: float = 0.0) -> float:
    """Irons' bound (module docstring) of the largest eigenvalue of M^-1 (sum of the springs'
    s_e d d^T [+ the triangles' drag]) in the rest state, 1/s^2 for K or 1/s for C."""
    n = model.particle_count
    w = model.inv_mass.astype(np.float64)
    pairs = model.constraint_indices
    u, degenerate = _spring_directions(model)
    blocks = spring_weight[:, None, None] * u[:, :, None] * u[:, None, :]
    blocks[degenerate] = spring_weight[degenerate, None, None] * np.eye(3)  # no direction: all of them
    local = np.zeros((n, 3, 3))
    np.add.at(local, pairs[:, 0], blocks)
    np.add.at(local, pairs[:, 1], blocks)
    tri = model.triangles
    use_drag = drag > 0 and tri.shape[0] > 0
    if use_drag:
        pos = model.rest_pos.astype(np.float64)
        m = np.cross(pos[tri[:, 1]] - pos[tri[:, 0]], pos[tri[:, 2]] - pos[tri[:, 0]])
        norm = np.linalg.norm(m, axis=1)
        normal = m / np.where(norm > 0, norm, 1.0)[:, None]
        share = drag * triangle_areas(model.rest_pos, tri) / 9.0
        tri_blocks = share[:, None, None] * normal[:, :, None] * normal[:, None, :]
        for corner in range(3):
            np.add.at(local, tri[:, corner], tri_blocks)
    per_particle = np.linalg.eigvalsh(local)[:, -1] * w if n else np.zeros(0)  # lambda_i / m_i, 0 pinned
    bound = float((per_particle[pairs[:, 0]] + per_particle[pairs[:, 1]]).max(initial=0.0))
    if use_drag:
        bound = max(bound, float(per_particle[tri].sum(axis=1).max(initial=0.0)))
    return bound


def any_configuration(model, stiffness: np.ndarray, damping: np.ndarray) -> float:
    """The configuration-free limit (block Gershgorin, direction-free, springs only), s."""
    n = model.particle_count
    w = model.inv_mass.astype(np.float64)
    a, b = model.constraint_indices[:, 0], model.constraint_indices[:, 1]
    cross = np.sqrt(w[a] * w[b])
    row_k, row_c = np.zeros(n), np.zeros(n)
    for end in (a, b):
        weight = np.where(w[end] > 0, w[end] + cross, 0.0)
        np.add.at(row_k, end, stiffness * weight)
        np.add.at(row_c, end, damping * weight)
    return step_limit(float(row_k.max(initial=0.0)), float(row_c.max(initial=0.0)))


def spring_limits(model, stiffness: np.ndarray, damping: np.ndarray) -> np.ndarray:
    """f64 (c,) each spring's own two-body limit 4 / (gamma + sqrt(gamma^2 + 4 omega^2))."""
    w = model.inv_mass.astype(np.float64)
    pairs = model.constraint_indices
    w_sum = w[pairs[:, 0]] + w[pairs[:, 1]]
    omega2 = stiffness * w_sum
    gamma = damping * w_sum
    denominator = gamma + np.sqrt(gamma * gamma + 4.0 * omega2)
    with np.errstate(divide="ignore"):
        return np.where(denominator > 0, 4.0 / np.where(denominator > 0, denominator, 1.0), np.inf)


def stability_report(model, environment=None) -> dict:
    """The figures the solver checks and the bake reports:

    h_max_s: the largest stable substep of the rest state (module docstring), seconds;
    min_frequency_hz: 1 / h_max_s;
    omega_max_rad_s, damping_rate_max_per_s: sqrt(Lambda_K) and Gamma;
    h_any_configuration_s: the (smaller) limit that holds in every configuration;
    stiffest_spring, h_stiffest_spring_s: the spring with the smallest two-body limit and that
        limit (optimistic: the cloth's fastest mode shares springs);
    factor: substeps up to factor * h_max_s are accepted.
    Pass the environment to include the wind stage's air drag.
    """
    stiffness = spring_stiffness(model)
    damping = spring_damping(model, stiffness)
    lambda_k = element_bound(model, stiffness)
    gamma = element_bound(model, damping, drag_coefficient(model, environment))
    h_max = step_limit(lambda_k, gamma)
    limits = spring_limits(model, stiffness, damping)
    stiffest = int(np.argmin(limits)) if limits.size else -1
    return {
        "h_max_s": h_max,
        "min_frequency_hz": 1.0 / h_max,
        "omega_max_rad_s": math.sqrt(lambda_k),
        "damping_rate_max_per_s": gamma,
        "h_any_configuration_s": any_configuration(model, stiffness, damping),
        "stiffest_spring": stiffest,
        "h_stiffest_spring_s": float(limits[stiffest]) if stiffest >= 0 else math.inf,
        "factor": FACTOR,
    }


def stability_limit(model, environment=None) -> float:
    """The largest stable symplectic Euler substep of ``model`` at rest, in seconds (module
    docstring); pass the environment to include the wind stage's air drag."""
    return stability_report(model, environment)["h_max_s"]
