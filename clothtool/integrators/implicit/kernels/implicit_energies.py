"""Baraff & Witkin's conditions as numba kernels: forces, df/dx and df/dv in one pass.

Every condition C(x) has the energy E = k/2 C^2, the force f = -k C dC/dx and the damping
force d = -k_d Cdot dC/dx with Cdot = dC/dx . v (the slides 11-16). Per element:

* stretch (per triangle, per axis u and v): C = a (|w_u| - 1), k = Y/a, where a is the rest
  area and Y the stretch modulus in N/m: E = Y a/2 (|w_u| - 1)^2, the membrane energy of a
  linear sheet, whatever the triangle size; an axis shorter than at rest uses
  ``compression`` Y (woven cloth buckles rather than compresses);
* shear (per triangle): C = a w_u . w_v, k = G/a with G the shear modulus in N/m;
* bend (per hinge): C = theta - theta_rest, k = D |e|^2/(A_a + A_b) (see ``rest``).

Damping is stiffness-proportional: k_d = damping_time * k (the solver derives damping_time).

Jacobians. df/dx = -k (dC/dx dC/dx^T + C d2C/dx2). The second term makes the matrix
indefinite under compression, so by default (``exact`` False) it is kept only where it is
positive semi-definite: for stretch while the axis is stretched (|w| > 1); it is dropped for
shear (a bilinear form, always indefinite) and bend (Gauss-Newton). With ``exact`` the
stretch and shear second-derivative terms are all kept (tests compare that with finite
differences). For damping, df/dv = -k_d dC/dx dC/dx^T exactly, and the terms of dd/dx
(the asymmetric dC/dx (d2C/dx2 v)^T and Cdot d2C/dx2) are dropped, as Baraff & Witkin
drop the asymmetric one.

Every kernel adds, per element: the force into ``force`` (n,3), (df/dx) v into
``jacobian_v`` (n,3) (for the right-hand side h^2 df/dx v0), and
-(x_weight df/dx + v_weight df/dv) into the block values (nnzb,3,3) at the element's
slots. With x_weight = h^2, v_weight = h this builds A - M of the backward Euler system.
Scene units throughout (the solver's docstring explains the scaling); float64. Helpers
(``_name``) are ``register_jitable`` pieces of the kernels, checked through them.
"""

from __future__ import annotations

import math

from numba import prange
from numba.extending import register_jitable as jitable

from clothtool._jit import kernel
from clothtool.integrators.implicit import vec
from clothtool.solver.kernels.air import triangle_air


@jitable
def _add_outer(blocks, slot, s, a, b, diagonal):
    """blocks[slot] += s a b^T + diagonal I"""
    for r in range(3):
        for q in range(3):
            blocks[slot, r, q] += s * a[r] * b[q]
        blocks[slot, r, r] += diagonal


# ----------------------------------------------------------------- triangles
@jitable
def _stretch_axis(ids, coef, w, dw, area, modulus, compression, damping_time, x_weight, v_weight, exact, force,
                  jacobian_v):
    """One stretch axis of one triangle: C = a (|w| - 1), w = sum_c coef_c x_c, the modulus
    scaled by ``compression`` while |w| < 1. Adds the force and (df/dx) v; returns (n, o, g):
    the axis adds coef_c coef_d (o n n^T + g I) to block (c,d)."""
    length = math.sqrt(vec.dot(w, w))
    if length < 1.0:
        modulus *= compression
    if modulus == 0.0 or length == 0.0:
        return (0.0, 0.0, 0.0), 0.0, 0.0
    n = vec.scale(1.0 / length, w)
    k = modulus / area
    kd = damping_time * k
    c_value = area * (length - 1.0)
    n_dw = vec.dot(n, dw)
    c_dot = area * n_dw
    bend_ratio = (length - 1.0) / length  # d2C/dx2 = a coef coef^T (I - n n^T) / |w|, times C
    if not exact and bend_ratio < 0.0:
        bend_ratio = 0.0
    f_scale = -(k * c_value + kd * c_dot) * area
    # (df/dx v)_c = -k a^2 coef_c (n n.dw + ratio (dw - n n.dw))
    kv = vec.scale(-k * area * area, vec.axpy(n_dw * (1.0 - bend_ratio), n, vec.scale(bend_ratio, dw)))
    for c in range(3):
        vec.add_row(force, ids[c], f_scale * coef[c], n)
        vec.add_row(jacobian_v, ids[c], coef[c], kv)
    along = area * area * (x_weight * k + v_weight * kd)
    across = area * area * x_weight * k * bend_ratio
    return n, along - across, across


@jitable
def _shear(ids, cu, cv, wu, wv, dwu, dwv, area, modulus, damping_time, x_weight, v_weight, exact, force, jacobian_v):
    """The shear condition C = a w_u . w_v of one triangle. Adds the force and (df/dx) v;
    returns (o, g): shear adds o g_c g_d^T + g (cu_c cv_d + cv_c cu_d) I to block (c,d),
    g_c = cu_c w_v + cv_c w_u."""
    if modulus == 0.0:
        return 0.0, 0.0
    k = modulus / area
    kd = damping_time * k
    c_value = area * vec.dot(wu, wv)
    c_dot = area * (vec.dot(dwu, wv) + vec.dot(wu, dwv))
    f_scale = -(k * c_value + kd * c_dot) * area
    second = c_value if exact else 0.0
    for c in range(3):
        g_c = vec.axpy(cu[c], wv, vec.scale(cv[c], wu))
        vec.add_row(force, ids[c], f_scale, g_c)
        # (df/dx v)_c = -k a (g_c Cdot + C (cu_c dwv + cv_c dwu))
        vec.add_row(jacobian_v, ids[c], -k * area,
                    vec.axpy(c_dot, g_c, vec.scale(second, vec.axpy(cu[c], dwv, vec.scale(cv[c], dwu)))))
    return area * area * (x_weight * k + v_weight * kd), x_weight * k * second * area


@jitable
def _triangle(t, triangles, tri_dinv, tri_area, triangle_slot, x, v, stretch_u, stretch_v, compression, shear,
              damping_time, x_weight, v_weight, exact, force, jacobian_v, blocks):
    area = tri_area[t]
    if area <= 0.0:
        return
    ids = (triangles[t, 0], triangles[t, 1], triangles[t, 2])
    d00, d01, d10, d11 = tri_dinv[t, 0], tri_dinv[t, 1], tri_dinv[t, 2], tri_dinv[t, 3]
    cu = (-(d00 + d10), d00, d10)
    cv = (-(d01 + d11), d01, d11)
    x0, x1, x2 = vec.row(x, ids[0]), vec.row(x, ids[1]), vec.row(x, ids[2])
    v0, v1, v2 = vec.row(v, ids[0]), vec.row(v, ids[1]), vec.row(v, ids[2])
    e1, e2 = vec.sub(x1, x0), vec.sub(x2, x0)
    wu = vec.axpy(d00, e1, vec.scale(d10, e2))
    wv = vec.axpy(d01, e1, vec.scale(d11, e2))
    dwu = vec.axpy(cu[0], v0, vec.axpy(cu[1], v1, vec.scale(cu[2], v2)))
    dwv = vec.axpy(cv[0], v0, vec.axpy(cv[1], v1, vec.scale(cv[2], v2)))
    nu, outer_u, diag_u = _stretch_axis(ids, cu, wu, dwu, area, stretch_u, compression, damping_time, x_weight, v_weight,
                                        exact, force, jacobian_v)
    nv, outer_v, diag_v = _stretch_axis(ids, cv, wv, dwv, area, stretch_v, compression, damping_time, x_weight, v_weight,
                                        exact, force, jacobian_v)
    outer_s, diag_s = _shear(ids, cu, cv, wu, wv, dwu, dwv, area, shear, damping_time, x_weight, v_weight, exact, force,
                             jacobian_v)
    slots = triangle_slot[t]
    for c in range(3):
        g_c = vec.axpy(cu[c], wv, vec.scale(cv[c], wu))
        for d in range(3):
            g_d = vec.axpy(cu[d], wv, vec.scale(cv[d], wu))
            uu = cu[c] * cu[d] * outer_u
            vv = cv[c] * cv[d] * outer_v
            diagonal = cu[c] * cu[d] * diag_u + cv[c] * cv[d] * diag_v + diag_s * (cu[c] * cv[d] + cv[c] * cu[d])
            slot = slots[3 * c + d]
            for r in range(3):
                for q in range(3):
                    blocks[slot, r, q] += uu * nu[r] * nu[q] + vv * nv[r] * nv[q] + outer_s * g_c[r] * g_d[q]
                blocks[slot, r, r] += diagonal


@kernel(parallel=True)
def triangle_terms(triangles, tri_dinv, tri_area, triangle_slot, order, offsets, x, v, stretch_u, stretch_v, compression,
                   shear, damping_time, x_weight, v_weight, exact, force, jacobian_v, blocks):
    """Stretch (moduli ``stretch_u``, ``stretch_v``, N/m, times ``compression`` for an axis
    shorter than at rest) and shear (``shear``, N/m) of every triangle; ``order``/``offsets``:
    the colouring (``pattern.color_elements``). Adds into force, jacobian_v (n,3) and blocks
    (nnzb,3,3) as the module docstring says."""
    for color in range(offsets.shape[0] - 1):
        for e in prange(offsets[color], offsets[color + 1]):
            _triangle(order[e], triangles, tri_dinv, tri_area, triangle_slot, x, v, stretch_u, stretch_v, compression,
                      shear, damping_time, x_weight, v_weight, exact, force, jacobian_v, blocks)


# ----------------------------------------------------------------- hinges
@jitable
def _hinge_angle_gradient(xa, xb, xs, xe):
    """(theta, g_a, g_b, g_s, g_e): the dihedral angle of ``rest.dihedral_angles`` and its
    gradient with respect to the wings a, b and the edge's start and end (Bridson et al.
    2003's bending modes, with the sign of theta). theta = nan for a degenerate hinge."""
    na = vec.cross(vec.sub(xa, xs), vec.sub(xa, xe))
    nb = vec.cross(vec.sub(xb, xe), vec.sub(xb, xs))
    edge = vec.sub(xe, xs)
    na2, nb2, length = vec.dot(na, na), vec.dot(nb, nb), math.sqrt(vec.dot(edge, edge))
    zero = (0.0, 0.0, 0.0)
    if na2 == 0.0 or nb2 == 0.0 or length == 0.0:
        return math.nan, zero, zero, zero, zero
    e = vec.scale(1.0 / length, edge)
    theta = math.atan2(vec.dot(vec.cross(na, nb), e), vec.dot(na, nb))
    ma = vec.scale(1.0 / na2, na)
    mb = vec.scale(1.0 / nb2, nb)
    g_a = vec.scale(-length, ma)
    g_b = vec.scale(-length, mb)
    g_s = vec.axpy(-vec.dot(vec.sub(xa, xe), e), ma, vec.scale(-vec.dot(vec.sub(xb, xe), e), mb))
    g_e = vec.axpy(vec.dot(vec.sub(xa, xs), e), ma, vec.scale(vec.dot(vec.sub(xb, xs), e), mb))
    return theta, g_a, g_b, g_s, g_e


@jitable
def _hinge(p, hinges, hinge_rest_angle, hinge_weight, hinge_slot, x, v, bend, damping_time, x_weight, v_weight,
           force, jacobian_v, blocks):
    k = bend * hinge_weight[p]
    if k == 0.0:
        return
    ids = (hinges[p, 0], hinges[p, 1], hinges[p, 2], hinges[p, 3])
    theta, g_a, g_b, g_s, g_e = _hinge_angle_gradient(vec.row(x, ids[0]), vec.row(x, ids[1]), vec.row(x, ids[2]), vec.row(x, ids[3]))
    if math.isnan(theta):
        return
    grads = (g_a, g_b, g_s, g_e)
    c_value = theta - hinge_rest_angle[p]
    if c_value > math.pi:
        c_value -= 2.0 * math.pi
    elif c_value < -math.pi:
        c_value += 2.0 * math.pi
    kd = damping_time * k
    c_dot = 0.0
    for c in range(4):
        c_dot += vec.dot(grads[c], vec.row(v, ids[c]))
    f_scale = -(k * c_value + kd * c_dot)
    weight = x_weight * k + v_weight * kd
    slots = hinge_slot[p]
    for c in range(4):
        vec.add_row(force, ids[c], f_scale, grads[c])
        vec.add_row(jacobian_v, ids[c], -k * c_dot, grads[c])
        for d in range(4):
            _add_outer(blocks, slots[4 * c + d], weight, grads[c], grads[d], 0.0)


@kernel(parallel=True)
def hinge_terms(hinges, hinge_rest_angle, hinge_weight, hinge_slot, order, offsets, x, v, bend, damping_time,
                x_weight, v_weight, force, jacobian_v, blocks):
    """Bending of every hinge with stiffness ``bend * hinge_weight`` (Gauss-Newton df/dx);
    adds into force, jacobian_v and blocks as the module docstring says."""
    for color in range(offsets.shape[0] - 1):
        for e in prange(offsets[color], offsets[color + 1]):
            _hinge(order[e], hinges, hinge_rest_angle, hinge_weight, hinge_slot, x, v, bend, damping_time,
                   x_weight, v_weight, force, jacobian_v, blocks)


# ----------------------------------------------------------------- air drag and lift
@kernel(parallel=True)
def drag_terms(triangles, triangle_slot, order, offsets, share, x, v, wind, drag, lift, density, v_weight, force, blocks):
    """Air drag and lift on each triangle, the law of ``clothtool.solver.kernels.air`` as the
    position-based wind stage applies it: corner c gets -share_c density G(u, m), a third of
    -1/2 rho A (C_d |u.n| u + lift) times its share (``clothtool.solver.air``, 1 on a
    triangle mesh), with u the mean corner velocity minus ``wind`` (3,), m the
    unnormalised normal (n = m / |m|, A = |m| / 2) and density = rho s^3 / 12.
    df/dv per corner pair (c, d), of the drag only: -(density C_d |m| |u.n| / 3)
    sqrt(share_c share_d) (I + n n^T), the symmetric positive part of the exact
    -(density C_d |m| / 3) share_c (|u.n| I + sign(u.n) u n^T) (equal to it for a face moving
    along its normal on a triangle mesh; n's dependence on x is ignored). The
    lift, at right angles to the motion, does no work and is left explicit. Adds -v_weight
    df/dv into blocks."""
    third = 1.0 / 3.0
    for color in range(offsets.shape[0] - 1):
        for e in prange(offsets[color], offsets[color + 1]):
            t = order[e]
            ids = (triangles[t, 0], triangles[t, 1], triangles[t, 2])
            x0 = vec.row(x, ids[0])
            normal = vec.cross(vec.sub(vec.row(x, ids[1]), x0), vec.sub(vec.row(x, ids[2]), x0))
            u = vec.scale(third, vec.axpy(1.0, vec.row(v, ids[0]), vec.axpy(1.0, vec.row(v, ids[1]), vec.row(v, ids[2]))))
            u = vec.sub(u, (wind[0], wind[1], wind[2]))
            gx, gy, gz, ok = triangle_air(u[0], u[1], u[2], normal[0], normal[1], normal[2], drag, lift)
            if not ok:
                continue
            double_area = math.sqrt(vec.dot(normal, normal))
            n = vec.scale(1.0 / double_area, normal)
            un = abs(vec.dot(u, n))
            slope = v_weight * density * drag * double_area * un * third
            g = (gx, gy, gz)
            slots = triangle_slot[t]
            root = (math.sqrt(share[ids[0]]), math.sqrt(share[ids[1]]), math.sqrt(share[ids[2]]))
            for c in range(3):
                vec.add_row(force, ids[c], -density * share[ids[c]], g)
                for d in range(3):
                    pair = slope * root[c] * root[d]
                    _add_outer(blocks, slots[3 * c + d], pair, n, n, pair)
