"""Fabric phases, set by set: NvCloth's edge constraints ("solveFabric").

For each constraint (a, b) with rest length r, h = pb - pa and

    er = 1 - r / sqrt(eps + |h|^2)              (0 when r = 0)
    er -= m * max(c, min(er, s))                (only when the multiplier m is not neutral)
    ex = er * k / (eps + wa + wb)
    pa += h * ex * wa ;  pb -= h * ex * wb

where k, m are the phase's per-iteration stiffness and multiplier (log-space converted),
c = 1 - 1/compression_limit and s = 1 - 1/stretch_limit, and k is further scaled by the
constraint's painted stiffness. A set shares no movable particle, so its constraints are
independent: the parallel kernel runs each set's loop on all cores and gives the same bits
as the serial one, whatever the thread count.
"""

from __future__ import annotations

import numba
import numpy as np

from clothtool._jit import kernel, serial_and_parallel

FLT_EPSILON = np.float32(1.1920929e-07)
# Guards sqrt and division when two particles coincide. NvCloth adds FLT_EPSILON here, which
# is in scene units squared: a 2 mm edge in a metre scene would rest 1.5% short and edges
# under 0.35 mm could never be satisfied. A guard far below any real length squared keeps
# the formulas exact while still avoiding 0/0.
DISTANCE_EPSILON = np.float32(1e-30)


@kernel(inline="always")
def _edge_slack(cur, a, b, r):
    """h = pb - pa, both inverse masses, and the slack er = 1 - r / |h| (0 when r = 0)."""
    hx = cur[b, 0] - cur[a, 0]
    hy = cur[b, 1] - cur[a, 1]
    hz = cur[b, 2] - cur[a, 2]
    e2 = DISTANCE_EPSILON + hx * hx + hy * hy + hz * hz
    er = np.float32(1.0) - r / np.sqrt(e2) if r > np.float32(0.0) else np.float32(0.0)
    return hx, hy, hz, cur[a, 3], cur[b, 3], er


@kernel(inline="always")
def _apply_edge(cur, a, b, hx, hy, hz, wa, wb, ex):
    """pa += h ex wa; pb -= h ex wb (the correction shared by inverse mass)."""
    fa = ex * wa
    fb = ex * wb
    cur[a, 0] += hx * fa
    cur[a, 1] += hy * fa
    cur[a, 2] += hz * fa
    cur[b, 0] -= hx * fb
    cur[b, 1] -= hy * fb
    cur[b, 2] -= hz * fb


def _solve_phases(indices, rest, constraint_stiffness, set_offsets, phase_set_offsets, phase_params, cur):
    """phase_params (p,4): per phase (stiffness, multiplier, compression term, stretch term)."""
    zero = np.float32(0.0)
    for p in range(phase_params.shape[0]):
        k = phase_params[p, 0]
        m = phase_params[p, 1]
        lo = phase_params[p, 2]
        hi = phase_params[p, 3]
        use_multiplier = m != zero
        for s in range(phase_set_offsets[p], phase_set_offsets[p + 1]):
            for c in numba.prange(set_offsets[s], set_offsets[s + 1]):
                a = indices[c, 0]
                b = indices[c, 1]
                hx, hy, hz, wa, wb, er = _edge_slack(cur, a, b, rest[c])
                if use_multiplier:
                    er -= m * max(lo, min(er, hi))
                _apply_edge(cur, a, b, hx, hy, hz, wa, wb, er * k * constraint_stiffness[c] / (FLT_EPSILON + wa + wb))


solve_phases, solve_phases_parallel = serial_and_parallel(_solve_phases)


def _solve_phases_xpbd(indices, rest, alpha_tilde, set_offsets, cur):
    """XPBD (Macklin et al. 2016) distance constraints, one iteration per substep.

    With the Lagrange multiplier reset every substep, the update of constraint c is
    dlambda = -C / (wa + wb + alpha_tilde_c), alpha_tilde_c = compliance_c / h^2, i.e. the
    edge-constraint update above with stiffness 1 and alpha_tilde in the denominator; as h
    shrinks the solution converges to the elastic material's instead of depending on h.
    """
    for s in range(set_offsets.shape[0] - 1):
        for c in numba.prange(set_offsets[s], set_offsets[s + 1]):
            a = indices[c, 0]
            b = indices[c, 1]
            hx, hy, hz, wa, wb, er = _edge_slack(cur, a, b, rest[c])
            _apply_edge(cur, a, b, hx, hy, hz, wa, wb, er / (FLT_EPSILON + wa + wb + alpha_tilde[c]))


solve_xpbd, solve_xpbd_parallel = serial_and_parallel(_solve_phases_xpbd)
