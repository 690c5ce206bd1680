"""Reference for clothtool.integrators.implicit.energies (and ``rest``'s hinge angle):
Baraff & Witkin's conditions in plain float64 numpy, written from the slides and the kernels'
docstrings.

Per condition C with stiffness k and damping k_d = damping_time k (a stretch axis shorter
than at rest has its modulus scaled by ``compression``):
E = k/2 C^2, f = -k C dC/dx - k_d Cdot dC/dx, df/dv = -k_d dC/dx dC/dx^T and
df/dx = -k (dC/dx dC/dx^T + C d2C/dx2) ("exact"), or the solver's filtered form: the
C d2C/dx2 term kept for stretch only where |w| > 1, dropped for shear and bend. Matrices are
dense (3n,3n), for small meshes.
"""

from __future__ import annotations

import numpy as np

from tests.reference import air


def _skew(c: np.ndarray) -> np.ndarray:
    """[c]x: the matrix with [c]x y = c x y."""
    return np.array([[0.0, -c[2], c[1]], [c[2], 0.0, -c[0]], [-c[1], c[0], 0.0]])


# ----------------------------------------------------------------- triangles
def triangle_conditions(x, tri, dinv, area):
    """Per triangle: corner coefficients cu, cv (3,), w_u, w_v (3,) and the conditions
    (C_u, C_v, C_shear) with their gradients (3 corners x 3) and Hessians (9,9)."""
    x = np.asarray(x, np.float64)
    d00, d01, d10, d11 = dinv
    cu = np.array([-(d00 + d10), d00, d10])
    cv = np.array([-(d01 + d11), d01, d11])
    xs = x[tri]
    wu = cu @ xs
    wv = cv @ xs
    out = []
    for coef, w in ((cu, wu), (cv, wv)):
        length = np.linalg.norm(w)
        n = w / length
        grad = area * coef[:, None] * n[None, :]
        hess = area * np.kron(np.outer(coef, coef), (np.eye(3) - np.outer(n, n)) / length)
        out.append((area * (length - 1.0), grad, hess, (length - 1.0) > 0))
    grad = area * (cu[:, None] * wv[None, :] + cv[:, None] * wu[None, :])
    hess = area * np.kron(np.outer(cu, cv) + np.outer(cv, cu), np.eye(3))
    out.append((area * wu @ wv, grad, hess, False))
    return out


def triangle_energy(x, triangles, tri_dinv, tri_area, stretch_u, stretch_v, shear, compression=1.0):
    """Total stretch and shear energy: sum of k/2 C^2 with k = modulus / area."""
    total = 0.0
    for t in range(triangles.shape[0]):
        if tri_area[t] <= 0:
            continue
        conditions = triangle_conditions(x, triangles[t], tri_dinv[t], tri_area[t])
        for axis, ((c, _, _, _), modulus) in enumerate(zip(conditions, (stretch_u, stretch_v, shear))):
            if axis < 2 and c < 0:
                modulus = modulus * compression
            total += 0.5 * modulus / tri_area[t] * c * c
    return total


def triangle_terms(triangles, tri_dinv, tri_area, x, v, stretch_u, stretch_v, shear, damping_time, exact, compression=1.0):
    """(force (n,3), df/dx (3n,3n), df/dv (3n,3n)) of all triangles."""
    n = np.asarray(x).shape[0]
    force = np.zeros((n, 3))
    dfdx = np.zeros((3 * n, 3 * n))
    dfdv = np.zeros((3 * n, 3 * n))
    v = np.asarray(v, np.float64)
    for t in range(triangles.shape[0]):
        a = tri_area[t]
        if a <= 0:
            continue
        ids = triangles[t]
        dofs = (3 * ids[:, None] + np.arange(3)).reshape(-1)
        conditions = triangle_conditions(x, ids, tri_dinv[t], a)
        for (c, grad, hess, stretched), modulus, is_shear in zip(conditions, (stretch_u, stretch_v, shear), (0, 0, 1)):
            if not is_shear and c < 0:
                modulus = modulus * compression
            if modulus == 0:
                continue
            k = modulus / a
            kd = damping_time * k
            g = grad.reshape(-1)
            c_dot = g @ v[ids].reshape(-1)
            force[ids] += (-(k * c + kd * c_dot) * g).reshape(3, 3)
            keep_second = exact or (not is_shear and stretched)
            block = -k * (np.outer(g, g) + (c * hess if keep_second else 0.0))
            dfdx[np.ix_(dofs, dofs)] += block
            dfdv[np.ix_(dofs, dofs)] += -kd * np.outer(g, g)
    return force, dfdx, dfdv


# ----------------------------------------------------------------- hinges
def hinge_angle(xa, xb, xs, xe):
    """atan2((n_a x n_b) . e, n_a . n_b), n_a = (xa - xs) x (xa - xe), n_b = (xb - xe) x (xb - xs)."""
    na = np.cross(xa - xs, xa - xe)
    nb = np.cross(xb - xe, xb - xs)
    e = (xe - xs) / np.linalg.norm(xe - xs)
    na = na / np.linalg.norm(na)
    nb = nb / np.linalg.norm(nb)
    return float(np.arctan2(np.cross(na, nb) @ e, na @ nb))


def _hinge_parts(xa, xb, xs, xe):
    na = np.cross(xa - xs, xa - xe)
    nb = np.cross(xb - xe, xb - xs)
    edge = xe - xs
    length = np.linalg.norm(edge)
    e = edge / length
    return na, nb, edge, length, e


def hinge_angle_gradient(xa, xb, xs, xe):
    """(4,3) d theta / d(xa, xb, xs, xe): -|E| m_a, -|E| m_b, -(alpha_a m_a + alpha_b m_b),
    beta_a m_a + beta_b m_b with m = N/|N|^2, alpha = (x_wing - x_e).e, beta = (x_wing - x_s).e."""
    na, nb, _, length, e = _hinge_parts(xa, xb, xs, xe)
    ma, mb = na / (na @ na), nb / (nb @ nb)
    return np.array([
        -length * ma,
        -length * mb,
        -((xa - xe) @ e) * ma - ((xb - xe) @ e) * mb,
        ((xa - xs) @ e) * ma + ((xb - xs) @ e) * mb,
    ])


def hinge_angle_hessian(xa, xb, xs, xe):
    """(12,12) second derivatives of the hinge angle, by differentiating the gradient's
    closed form term by term (products of scalars s(x) and vectors m = N/|N|^2)."""
    na, nb, edge, length, e = _hinge_parts(xa, xb, xs, xe)
    ma, mb = na / (na @ na), nb / (nb @ nb)
    eye = np.eye(3)
    zero = np.zeros((3, 3))
    # dm/dx_j = (I - 2 n n^T)/|N|^2 dN/dx_j, vertex order (a, b, s, e)
    pa = (eye - 2.0 * np.outer(na, na) / (na @ na)) / (na @ na)
    pb = (eye - 2.0 * np.outer(nb, nb) / (nb @ nb)) / (nb @ nb)
    dna = [_skew(edge), zero, _skew(xa - xe), _skew(xs - xa)]
    dnb = [zero, -_skew(edge), _skew(xe - xb), _skew(xb - xs)]
    dma = [pa @ d for d in dna]
    dmb = [pb @ d for d in dnb]
    q = (eye - np.outer(e, e)) / length  # de/dx_e; de/dx_s = -q
    zero3 = np.zeros(3)
    d_length = [zero3, zero3, -e, e]

    def d_projection(wing_index, anchor_index):
        """gradient of (x_wing - x_anchor) . e over the four vertices (a, b, s, e)."""
        p = (xa, xb)[wing_index]
        anchor = xs if anchor_index == 2 else xe
        grads = [zero3.copy() for _ in range(4)]
        grads[wing_index] = grads[wing_index] + e
        grads[anchor_index] = grads[anchor_index] - e
        grads[3] = grads[3] + q @ (p - anchor)
        grads[2] = grads[2] - q @ (p - anchor)
        return grads

    alpha_a, alpha_b = d_projection(0, 3), d_projection(1, 3)
    beta_a, beta_b = d_projection(0, 2), d_projection(1, 2)
    # gradient entries as (scalar, d scalar, m, dm) products
    terms = [
        [(-length, [-g for g in d_length], ma, dma)],
        [(-length, [-g for g in d_length], mb, dmb)],
        [(-((xa - xe) @ e), [-g for g in alpha_a], ma, dma), (-((xb - xe) @ e), [-g for g in alpha_b], mb, dmb)],
        [(((xa - xs) @ e), beta_a, ma, dma), (((xb - xs) @ e), beta_b, mb, dmb)],
    ]
    hessian = np.zeros((12, 12))
    for i in range(4):
        for j in range(4):
            block = np.zeros((3, 3))
            for s, ds, m, dm in terms[i]:
                block += np.outer(m, ds[j]) + s * dm[j]
            hessian[3 * i:3 * i + 3, 3 * j:3 * j + 3] = block
    return hessian


def hinge_energy(x, hinges, rest_angle, stiffness):
    """sum of k/2 (theta - theta_rest)^2 over the hinges (stiffness (p,))."""
    total = 0.0
    for p in range(hinges.shape[0]):
        c = hinge_angle(*(np.asarray(x, np.float64)[hinges[p]])) - rest_angle[p]
        c = (c + np.pi) % (2 * np.pi) - np.pi
        total += 0.5 * stiffness[p] * c * c
    return total


def hinge_terms(hinges, rest_angle, stiffness, x, v, damping_time, exact):
    """(force (n,3), df/dx (3n,3n), df/dv (3n,3n)) of all hinges (stiffness (p,))."""
    x = np.asarray(x, np.float64)
    v = np.asarray(v, np.float64)
    n = x.shape[0]
    force = np.zeros((n, 3))
    dfdx = np.zeros((3 * n, 3 * n))
    dfdv = np.zeros((3 * n, 3 * n))
    for p in range(hinges.shape[0]):
        ids = hinges[p]
        k = stiffness[p]
        kd = damping_time * k
        g = hinge_angle_gradient(*x[ids]).reshape(-1)
        c = hinge_angle(*x[ids]) - rest_angle[p]
        c = (c + np.pi) % (2 * np.pi) - np.pi
        c_dot = g @ v[ids].reshape(-1)
        force[ids] += (-(k * c + kd * c_dot) * g).reshape(4, 3)
        dofs = (3 * ids[:, None] + np.arange(3)).reshape(-1)
        second = c * hinge_angle_hessian(*x[ids]) if exact else 0.0
        dfdx[np.ix_(dofs, dofs)] += -k * (np.outer(g, g) + second)
        dfdv[np.ix_(dofs, dofs)] += -kd * np.outer(g, g)
    return force, dfdx, dfdv


# ----------------------------------------------------------------- drag
def drag_terms(triangles, share, x, v, wind, drag, lift, density):
    """(force (n,3), df/dv (3n,3n)): corner c gets -share_c density G(u, m) of
    tests/reference/air.py (a third of the triangle's drag and lift times the particle's
    share, u = mean corner velocity - wind), and the kernel's symmetric drag df/dv
    -(density C_d |m| |u.n| / 3) sqrt(share_c share_d) (I + n n^T) per corner pair."""
    x = np.asarray(x, np.float64)
    v = np.asarray(v, np.float64)
    n = x.shape[0]
    force = np.zeros((n, 3))
    dfdv = np.zeros((3 * n, 3 * n))
    for ids in triangles:
        normal = np.cross(x[ids[1]] - x[ids[0]], x[ids[2]] - x[ids[0]])
        double_area = np.linalg.norm(normal)
        unit = normal / double_area
        u = v[ids].mean(axis=0) - wind
        gx, gy, gz, ok = air.triangle_air(*u, *normal, drag, lift)
        if not ok:
            continue
        weight = np.asarray(share, np.float64)[ids]
        force[ids] += -density * np.outer(weight, [gx, gy, gz])
        un = abs(u @ unit)
        dofs = (3 * ids[:, None] + np.arange(3)).reshape(-1)
        root = np.sqrt(weight)
        block = -(density * drag * double_area * un / 3) * (np.eye(3) + np.outer(unit, unit))
        dfdv[np.ix_(dofs, dofs)] += np.kron(np.outer(root, root), block)
    return force, dfdv
