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
from clothtool._minmax import largest, smallest
from clothtool._simd import fill, is_double, keep_w, lane, load4, store4, transpose4, vadd, vmul, vsub, w_lanes

FLT_EPSILON = np.float32(1.1920929e-07)
# Guards sqrt and division when two particles coincide. NvCloth adds FLT_EPSILON here, which
# is in scene units squared: a 2 mm edge in a metre scene would rest 1.5% short and edges
# under 0.35 mm could never be satisfied. A guard far below any real length squared keeps
# the formulas exact while still avoiding 0/0.
DISTANCE_EPSILON = np.float32(1e-30)


# A set is solved in blocks of BLOCK constraints, in three passes: measure every edge of the
# block (four constraints at a time: their rows transposed so that |h|^2 is three lane-wise
# multiply-adds), compute every correction (arithmetic over contiguous arrays, which LLVM
# vectorises eight constraints wide: the square root and divisions that bound a
# one-constraint-at-a-time loop), then move every pair of ends. Inside a set no movable
# particle appears twice, so measuring all before moving any changes nothing (a pinned
# particle, w = 0, shared by two constraints is written back unchanged). The scratch of a
# block (3 KB) stays in L1 between its passes. Blocks start at multiples of BLOCK from their
# set's start whoever runs them: which constraints are measured four at a time does not
# depend on the thread count, so results are bit-identical.
# All indices are unsigned (np.uintp): numba then emits no negative-index wraparound code,
# which would keep LLVM from vectorising the loops over contiguous arrays.
# In float64 (the default state) the correction pass is bound by the divider: a float64
# square root or division takes about twice a float32 one's slots, and the pass did one
# root and two divisions per constraint (a third of the float64 kernel's time, against a
# fifth of float32's). There it does one root and one division, 1/(|h| d) for the
# denominator d, and gets 1/|h| and 1/d back by multiplying by d and |h| (_slack_over):
# 1.22 -> 1.00 ns a constraint on Zen 4. (Float32 estimates of 1/|h| and 1/d refined by
# float64 Newton steps cost about what they save there: 1.16 ns.) float32 state keeps its
# root and two divisions, bit for bit.
BLOCK = 256

# Work on all cores (clothtool.solver.fabric_layers): the phases are grouped into layers of
# groups; groups of one layer share no particle. A layer of several groups (a big cloth's
# cache tiles, clothtool.cook.tiles) runs its groups on the cores, each group's phases and
# sets in order on one core, with the scratch of a BLOCK of its own; a layer of one group
# (a small cloth's phase) runs each set's blocks on the cores. Either way every constraint
# sees what it would see in the serial order of the sets.


@kernel(inline="always")
def _scratch_size(set_offsets, layer_group_offsets):
    """Scratch rows: the largest set (one layer of one group) or a BLOCK per group."""
    rows = 0
    for s in range(set_offsets.shape[0] - 1):
        rows = largest(rows, set_offsets[s + 1] - set_offsets[s])
    for layer in range(layer_group_offsets.shape[0] - 1):
        rows = largest(rows, (layer_group_offsets[layer + 1] - layer_group_offsets[layer]) * BLOCK)
    return rows


@kernel(inline="always")
def _measure_edges(cur, indices, first, count, at, length2, wa, wb):
    """Constraints first .. first+count-1: length2 = eps + |pb - pa|^2 and the two inverse
    masses, at scratch rows at .. at+count-1. ``cur`` is the flat (n*4,) view of the particles."""
    one = np.uintp(1)
    two = np.uintp(2)
    three = np.uintp(3)
    four = np.uintp(4)
    quads_end = count // four * four
    for quad in range(quads_end // four):
        i = four * quad
        c = first + i
        j = at + i
        a0 = load4(cur, 4 * indices[c, 0])
        b0 = load4(cur, 4 * indices[c, 1])
        a1 = load4(cur, 4 * indices[c + one, 0])
        b1 = load4(cur, 4 * indices[c + one, 1])
        a2 = load4(cur, 4 * indices[c + two, 0])
        b2 = load4(cur, 4 * indices[c + two, 1])
        a3 = load4(cur, 4 * indices[c + three, 0])
        b3 = load4(cur, 4 * indices[c + three, 1])
        hx, hy, hz, _ = transpose4(vsub(b0, a0), vsub(b1, a1), vsub(b2, a2), vsub(b3, a3))
        store4(length2, j, vadd(vadd(vadd(fill(hx, DISTANCE_EPSILON), vmul(hx, hx)), vmul(hy, hy)), vmul(hz, hz)))
        store4(wa, j, w_lanes(a0, a1, a2, a3))
        store4(wb, j, w_lanes(b0, b1, b2, b3))
    for i in range(quads_end, count):
        c = first + i
        j = at + i
        pa = load4(cur, 4 * indices[c, 0])
        pb = load4(cur, 4 * indices[c, 1])
        h = vsub(pb, pa)
        hx = lane(h, 0)
        hy = lane(h, 1)
        hz = lane(h, 2)
        length2[j] = DISTANCE_EPSILON + hx * hx + hy * hy + hz * hz  # the quads' multiply-add chain
        wa[j] = lane(pa, 3)
        wb[j] = lane(pb, 3)


@kernel(inline="always")
def _move_ends(cur, indices, first, count, at, fa, fb):
    """pa += h fa; pb -= h fb for h = pb - pa (the inverse masses are kept)."""
    for i in range(count):
        c = first + i
        j = at + i
        a = 4 * indices[c, 0]
        b = 4 * indices[c, 1]
        pa = load4(cur, a)
        pb = load4(cur, b)
        h = vsub(pb, pa)
        moved_a = keep_w(vadd(pa, vmul(h, fill(h, fa[j]))), pa)
        moved_b = keep_w(vsub(pb, vmul(h, fill(h, fb[j]))), pb)
        store4(cur, a, moved_a)
        store4(cur, b, moved_b)


@kernel(inline="always")
def _edge_slack(rest, length2):
    """er = 1 - r / |h| (0 when r = 0), from length2 = eps + |h|^2."""
    return np.float32(1.0) - rest / np.sqrt(length2) if rest > np.float32(0.0) else np.float32(0.0)


@kernel(inline="always")
def _slack_over(rest, length2, denominator):
    """float64: (er, 1/d) for er = 1 - r / |h| (0 when r = 0) and d = ``denominator``, from
    one root and one division: t = 1 / (|h| d), er = (|h| - r) t d and 1/d = t |h|. 1/d is
    within a few roundings of itself (|h|'s own rounding cancels); er within the rounding of
    |h| (about 1e-16 absolute, as ``1 - r / |h|``, which adds the division's) plus a few
    roundings of er itself (|h| - r is exact when r is near |h|)."""
    length = np.sqrt(length2)
    t = 1.0 / (length * denominator)
    er = (length - rest) * (t * denominator) if rest > np.float32(0.0) else 0.0
    return er, t * length


@kernel(inline="always")
def _edge_block(flat, indices, rest, constraint_stiffness, params, p, first, count, at, length2, wa, wb):
    """NvCloth's update of constraints first .. first+count-1 (one BLOCK at most) of phase p."""
    k = params[p, 0]
    m = params[p, 1]
    lo_limit = params[p, 2]
    hi_limit = params[p, 3]
    _measure_edges(flat, indices, first, count, at, length2, wa, wb)
    if is_double(length2):  # a constant of the compiled kernel: one loop or the other
        for i in range(count):
            c = first + i
            j = at + i
            er, inverse = _slack_over(rest[c], length2[j], FLT_EPSILON + wa[j] + wb[j])
            if m != np.float32(0.0):
                er -= m * largest(lo_limit, smallest(er, hi_limit))
            ex = er * k * constraint_stiffness[c] * inverse
            wa[j] *= ex
            wb[j] *= ex
    else:
        for i in range(count):
            c = first + i
            j = at + i
            er = _edge_slack(rest[c], length2[j])
            if m != np.float32(0.0):
                er -= m * largest(lo_limit, smallest(er, hi_limit))
            ex = er * k * constraint_stiffness[c] / (FLT_EPSILON + wa[j] + wb[j])
            wa[j] *= ex
            wb[j] *= ex
    _move_ends(flat, indices, first, count, at, wa, wb)


@kernel(inline="always")
def _xpbd_block(flat, indices, rest, alpha_tilde, params, p, first, count, at, length2, wa, wb):
    """The XPBD update of constraints first .. first+count-1 (``params`` and p unused)."""
    _measure_edges(flat, indices, first, count, at, length2, wa, wb)
    if is_double(length2):  # as in _edge_block
        for i in range(count):
            c = first + i
            j = at + i
            er, inverse = _slack_over(rest[c], length2[j], FLT_EPSILON + wa[j] + wb[j] + alpha_tilde[c])
            ex = er * inverse
            wa[j] *= ex
            wb[j] *= ex
    else:
        for i in range(count):
            c = first + i
            j = at + i
            ex = _edge_slack(rest[c], length2[j]) / (FLT_EPSILON + wa[j] + wb[j] + alpha_tilde[c])
            wa[j] *= ex
            wb[j] *= ex
    _move_ends(flat, indices, first, count, at, wa, wb)


def _make_solver(xpbd: bool):
    """The layered phase loop around ``_xpbd_block`` or ``_edge_block`` (see the comment
    above BLOCK). ``xpbd`` is a closure constant (numba prunes the other branch before typing):
    a captured function would pickle differently in every process and defeat the cache."""

    def solve(indices, rest, per_constraint, set_offsets, phase_set_offsets, params, layer_group_offsets,
              group_phase_offsets, cur):
        flat = cur.reshape(-1)
        scratch = np.empty((3, _scratch_size(set_offsets, layer_group_offsets)), cur.dtype)
        length2 = scratch[0]
        wa = scratch[1]  # the inverse masses, then the per-end factors ex * w
        wb = scratch[2]
        for layer in range(layer_group_offsets.shape[0] - 1):
            g0 = layer_group_offsets[layer]
            groups = layer_group_offsets[layer + 1] - g0
            if groups == 1:
                for p in range(group_phase_offsets[g0], group_phase_offsets[g0 + 1]):
                    for s in range(phase_set_offsets[p], phase_set_offsets[p + 1]):
                        first = np.uintp(set_offsets[s])
                        size = set_offsets[s + 1] - set_offsets[s]
                        for block in numba.prange((size + BLOCK - 1) // BLOCK):
                            lo = np.uintp(block * BLOCK)
                            count = np.uintp(smallest(BLOCK, size - block * BLOCK))
                            if xpbd:
                                _xpbd_block(flat, indices, rest, per_constraint, params, p, first + lo, count, lo, length2, wa, wb)
                            else:
                                _edge_block(flat, indices, rest, per_constraint, params, p, first + lo, count, lo, length2, wa, wb)
            else:
                for g_in_layer in numba.prange(groups):
                    g = g0 + g_in_layer
                    at = np.uintp(g_in_layer * BLOCK)
                    for p in range(group_phase_offsets[g], group_phase_offsets[g + 1]):
                        for s in range(phase_set_offsets[p], phase_set_offsets[p + 1]):
                            first = np.uintp(set_offsets[s])
                            size = set_offsets[s + 1] - set_offsets[s]
                            for block in range((size + BLOCK - 1) // BLOCK):
                                lo = np.uintp(block * BLOCK)
                                count = np.uintp(smallest(BLOCK, size - block * BLOCK))
                                if xpbd:
                                    _xpbd_block(flat, indices, rest, per_constraint, params, p, first + lo, count, at, length2, wa, wb)
                                else:
                                    _edge_block(flat, indices, rest, per_constraint, params, p, first + lo, count, at, length2, wa, wb)

    return solve


_solve_phases = _make_solver(False)
_solve_phases.__doc__ = """NvCloth's edge constraints, phase by phase. params (p,4): per phase (stiffness,
multiplier, compression term, stretch term); per_constraint: the painted stiffness."""
_solve_phases.__name__ = _solve_phases.__qualname__ = "_solve_phases"
solve_phases, solve_phases_parallel = serial_and_parallel(_solve_phases)

_solve_phases_xpbd = _make_solver(True)
_solve_phases_xpbd.__doc__ = """XPBD (Macklin et al. 2016) distance constraints, one iteration per substep.

With the Lagrange multiplier reset every substep, the update of constraint c is
dlambda = -C / (wa + wb + alpha_tilde_c), alpha_tilde_c = compliance_c / h^2, i.e. the
edge-constraint update above with stiffness 1 and alpha_tilde (per_constraint) in the
denominator; as h shrinks the solution converges to the elastic material's instead of
depending on h. params is unused (pass any (p,4) array)."""
_solve_phases_xpbd.__name__ = _solve_phases_xpbd.__qualname__ = "_solve_phases_xpbd"
solve_xpbd, solve_xpbd_parallel = serial_and_parallel(_solve_phases_xpbd)
