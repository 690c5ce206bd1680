"""The air law: drag and lift on one triangle, shared by all three integrators.

A triangle of area A and unit normal n moving at u relative to the air (its mean corner
velocity minus the wind) feels, with cos = n.u / |u| and air density rho,

    drag  F_d = -1/2 rho C_d A |cos| |u| u
              = -1/2 rho C_d A |n.u| u               magnitude 1/2 rho C_d A |u|^2 |cos|
    lift  F_l = -1/2 rho C_l A cos sin |u|^2 l       l = ((u x n) x u) / |(u x n) x u|
              = -1/2 rho C_l A (n.u) (|u| n - (n.u) u / |u|)

the seed's F_d = 1/2 rho v^2 c_drag A and F_l = c_lift 1/2 rho v^2 A with the normal speed
setting the drag and sin(2 theta) / 2 the lift ("at its maximum when d is at 45 degrees").
l is the unit vector at right angles to u in the plane of u and n. (The seed's lift direction has length |u| sin,
not the |u| its comment states, so the seed's lift peaks at 55 degrees as cos sin^2.) The
sign of n does not matter: both terms have it twice. No speed is too small for the law; only
a triangle without area or motion relative to the air gets no force.

Each corner gets a third of the triangle's force. That is the split that matches the lumped
masses (a particle's mass is its share of the areas of the faces around it), so a flat sheet
falling face-on accelerates evenly and reaches the textbook terminal speed; a mass-weighted
split would not (a triangle's corner masses are not its own mass, they count the
neighbours' areas too).

``triangle_air`` returns G = |m| (C_d |n.u| u + C_l (n.u)(|u| n - (n.u) u / |u|)) for the
unnormalised normal m (|m| = 2A): the force on each corner is -G rho/12 (F = -rho/4 G, a
third each) in any consistent units (the callers fold rho and the length units into one
coefficient). G is homogeneous: degree 1 in m, 2 in u, so a displacement over an iteration
may stand in for u. numba caches kernels by their own source file: after editing this
module, delete the cached code of the kernels that inline it (clothtool/**/__pycache__/*.nbi,
*.nbc).
"""

from __future__ import annotations

import numpy as np

from clothtool._jit import kernel


@kernel(inline="always")
def triangle_air(ux, uy, uz, mx, my, mz, drag, lift):
    """(G_x, G_y, G_z, ok) of the module docstring for the relative motion u and the
    unnormalised normal m; ok is False (and G not finite) without area or motion. Scalars
    of the caller's float type: a plain expression that the wind stage's loop vectorises."""
    double_area = np.sqrt(mx * mx + my * my + mz * mz)
    speed = np.sqrt(ux * ux + uy * uy + uz * uz)
    ok = (double_area > 0) & (speed > 0)
    normal_speed = (mx * ux + my * uy + mz * uz) / double_area  # n.u
    # G = (C_d |n.u| |m| - C_l (n.u)^2 |m| / |u|) u + C_l (n.u) |u| m
    along_u = (drag * abs(normal_speed) - lift * normal_speed * normal_speed / speed) * double_area
    along_m = lift * normal_speed * speed
    return along_u * ux + along_m * mx, along_u * uy + along_m * my, along_u * uz + along_m * mz, ok
