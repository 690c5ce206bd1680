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
from clothtool._simd import fill, keep_w, lane, load4, store4, vadd, vmul, vsub

FLT_EPSILON = np.float32(1.1920929e-07)
# Guards sqrt and division when two particles coincide. NvCloth adds FLT_EPSILON here, which
# is in scene units squared: a 2 mm edge in a metre scene would rest 1.5% short and edges
# under 0.35 mm could never be satisfied. A guard far below any real length squared keeps
# the formulas exact while still avoiding 0/0.
DISTANCE_EPSILON = np.float32(1e-30)


# A set is solved in blocks of BLOCK constraints, in three passes: measure every edge of the
# block (loads only), compute every correction (arithmetic over contiguous arrays, which LLVM
# vectorises eight constraints wide: the square root and divisions that bound a one-constraint-
# at-a-time loop), then move every pair of ends. Inside a set no movable particle appears
# twice, so measuring all before moving any changes nothing (a pinned particle, w = 0, shared
# by two constraints is written back unchanged). The scratch rows of a block (3 KB) stay in
# L1 between its passes. Blocks are the parallel kernels' unit of work: a constraint's
# arithmetic does not depend on which thread runs its block, so results are bit-identical.
BLOCK = 256


@kernel(inline="always")
def _largest_set(set_offsets):
    largest = 0
    for s in range(set_offsets.shape[0] - 1):
        largest = max(largest, set_offsets[s + 1] - set_offsets[s])
    return largest


@kernel(inline="always")
def _measure_edges(cur, indices, first, lo, hi, scratch):
    """Constraints first+lo .. first+hi of a set: scratch[0] = eps + |pb - pa|^2 and
    scratch[1] = eps + wa + wb, at lo .. hi. ``cur`` is the flat (n*4,) view of the particles.
    All indices are unsigned (np.uintp): numba then emits no negative-index wraparound, which
    would keep LLVM from vectorising the loops over contiguous rows."""
    for j in range(lo, hi):
        c = first + j
        pa = load4(cur, 4 * indices[c, 0])
        pb = load4(cur, 4 * indices[c, 1])
        h = vsub(pb, pa)
        h2 = vmul(h, h)
        scratch[0, j] = DISTANCE_EPSILON + lane(h2, 0) + lane(h2, 1) + lane(h2, 2)
        scratch[1, j] = FLT_EPSILON + lane(pa, 3) + lane(pb, 3)


@kernel(inline="always")
def _move_ends(cur, indices, first, lo, hi, scratch):
    """pa += h ex wa; pb -= h ex wb with ex = scratch[2] (the inverse masses are kept)."""
    for j in range(lo, hi):
        c = first + j
        a = 4 * indices[c, 0]
        b = 4 * indices[c, 1]
        pa = load4(cur, a)
        pb = load4(cur, b)
        h = vsub(pb, pa)
        ex = scratch[2, j]
        moved_a = keep_w(vadd(pa, vmul(h, fill(h, ex * lane(pa, 3)))), pa)
        moved_b = keep_w(vsub(pb, vmul(h, fill(h, ex * lane(pb, 3)))), pb)
        store4(cur, a, moved_a)
        store4(cur, b, moved_b)


@kernel(inline="always")
def _edge_slack(rest, length2):
    """er = 1 - r / |h| (0 when r = 0), from length2 = eps + |h|^2."""
    return np.float32(1.0) - rest / np.sqrt(length2) if rest > np.float32(0.0) else np.float32(0.0)


def _solve_phases(indices, rest, constraint_stiffness, set_offsets, phase_set_offsets, phase_params, cur):
    """phase_params (p,4): per phase (stiffness, multiplier, compression term, stretch term)."""
    flat = cur.reshape(-1)
    scratch = np.empty((3, _largest_set(set_offsets)), cur.dtype)
    for p in range(phase_params.shape[0]):
        k = phase_params[p, 0]
        m = phase_params[p, 1]
        lo_limit = phase_params[p, 2]
        hi_limit = phase_params[p, 3]
        use_multiplier = m != np.float32(0.0)
        for s in range(phase_set_offsets[p], phase_set_offsets[p + 1]):
            first = np.uintp(set_offsets[s])
            size = set_offsets[s + 1] - set_offsets[s]
            for block in numba.prange((size + BLOCK - 1) // BLOCK):
                lo = np.uintp(block * BLOCK)
                hi = np.uintp(min(block * BLOCK + BLOCK, size))
                _measure_edges(flat, indices, first, lo, hi, scratch)
                for j in range(lo, hi):
                    c = first + j
                    er = _edge_slack(rest[c], scratch[0, j])
                    if use_multiplier:
                        er -= m * max(lo_limit, min(er, hi_limit))
                    scratch[2, j] = er * k * constraint_stiffness[c] / scratch[1, j]
                _move_ends(flat, indices, first, lo, hi, scratch)


solve_phases, solve_phases_parallel = serial_and_parallel(_solve_phases)


def _solve_phases_xpbd(indices, rest, alpha_tilde, set_offsets, cur):
    """XPBD (Macklin et al. 2016) distance constraints, one iteration per substep.

    With the Lagrange multiplier reset every substep, the update of constraint c is
    dlambda = -C / (wa + wb + alpha_tilde_c), alpha_tilde_c = compliance_c / h^2, i.e. the
    edge-constraint update above with stiffness 1 and alpha_tilde in the denominator; as h
    shrinks the solution converges to the elastic material's instead of depending on h.
    """
    flat = cur.reshape(-1)
    scratch = np.empty((3, _largest_set(set_offsets)), cur.dtype)
    for s in range(set_offsets.shape[0] - 1):
        first = np.uintp(set_offsets[s])
        size = set_offsets[s + 1] - set_offsets[s]
        for block in numba.prange((size + BLOCK - 1) // BLOCK):
            lo = np.uintp(block * BLOCK)
            hi = np.uintp(min(block * BLOCK + BLOCK, size))
            _measure_edges(flat, indices, first, lo, hi, scratch)
            for j in range(lo, hi):
                c = first + j
                scratch[2, j] = _edge_slack(rest[c], scratch[0, j]) / (scratch[1, j] + alpha_tilde[c])
            _move_ends(flat, indices, first, lo, hi, scratch)


solve_xpbd, solve_xpbd_parallel = serial_and_parallel(_solve_phases_xpbd)
