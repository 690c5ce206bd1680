"""Reference for clothtool.solver.kernels.fabric: the seed's "Edge constraints" (solveFabric).

For each constraint (a, b), rest length r, painted stiffness s, and its phase's per-iteration
stiffness k, multiplier m, compression term lo = 1 - 1/compressionLimit and stretch term
hi = 1 - 1/stretchLimit:

    h  = p_b - p_a ;  e2 = eps + |h|^2
    er = 1 - r / sqrt(e2)                 (0 for r <= eps: a zero rest length never pulls)
    er -= m * max(lo, min(er, hi))        (only when the multiplier is not neutral, m != 0)
    ex = er * k * s / (eps + w_a + w_b)   (eps: two pinned ends give 0, not 0/0)
    p_a += h * ex * w_a ;  p_b -= h * ex * w_b

Gauss-Seidel: phases run in order, and the sets of a phase in order, each set seeing the
positions the sets before it left. Inside a set no movable particle appears twice, so its
constraints are independent and are solved here all at once, scattered with np.add.at.

XPBD (Macklin et al. 2016, "XPBD: Position-Based Simulation of Compliant Constrained
Dynamics"), one iteration per substep so the multiplier starts at 0: for C = |h| - r with
gradients -h^ at a and +h^ at b, dlambda = -C / (w_a + w_b + alpha~) and p += w grad(C) dlambda,
which is the update above with k = s = 1, no multiplier, and alpha~ = compliance / h^2 added to
the denominator (the kernel's docstring; it keeps the eps regularisation of |h| and of w_a + w_b).
"""

from __future__ import annotations

import numpy as np

FLT_EPSILON = float(np.finfo(np.float32).eps)
DISTANCE_EPSILON = 1e-30  # the kernels' guard for coincident particles


def _solve_set(pairs, rest, stiffness, k, m, lo, hi, cur, alpha_tilde=0.0):
    a, b = pairs[:, 0], pairs[:, 1]
    wa, wb = cur[a, 3], cur[b, 3]
    moving = np.concatenate([a[wa > 0], b[wb > 0]])
    if np.unique(moving).size != moving.size:
        raise ValueError("a set moves one particle twice: it is not conflict-free")
    h = cur[b, :3] - cur[a, :3]
    e2 = DISTANCE_EPSILON + np.einsum("ij,ij->i", h, h)
    er = np.where(rest > 0.0, 1.0 - rest / np.sqrt(e2), 0.0)
    if m != 0.0:
        er = er - m * np.maximum(lo, np.minimum(er, hi))
    ex = er * k * stiffness / (FLT_EPSILON + wa + wb + alpha_tilde)
    xyz = cur[:, :3]  # a view: np.add.at scatters into cur
    np.add.at(xyz, a, h * (ex * wa)[:, None])
    np.add.at(xyz, b, -h * (ex * wb)[:, None])


def solve_phases(indices, rest, constraint_stiffness, set_offsets, phase_set_offsets, phase_params, cur):
    """All phases once; phase_params (p,4) = (k, m, lo, hi). Returns cur as a float64 copy."""
    cur = np.array(cur, np.float64)
    indices = np.asarray(indices, np.int64)
    rest = np.asarray(rest, np.float64)
    stiffness = np.asarray(constraint_stiffness, np.float64)
    params = np.asarray(phase_params, np.float64)
    for p in range(params.shape[0]):
        k, m, lo, hi = params[p]
        for s in range(phase_set_offsets[p], phase_set_offsets[p + 1]):
            rows = slice(set_offsets[s], set_offsets[s + 1])
            _solve_set(indices[rows], rest[rows], stiffness[rows], k, m, lo, hi, cur)
    return cur


def solve_xpbd(indices, rest, alpha_tilde, set_offsets, cur):
    """Every set once, in order, with the XPBD update; alpha_tilde (c,) = compliance / h^2.
    Returns cur as a float64 copy."""
    cur = np.array(cur, np.float64)
    indices = np.asarray(indices, np.int64)
    rest = np.asarray(rest, np.float64)
    alpha_tilde = np.asarray(alpha_tilde, np.float64)
    for s in range(len(set_offsets) - 1):
        rows = slice(set_offsets[s], set_offsets[s + 1])
        _solve_set(indices[rows], rest[rows], 1.0, 1.0, 0.0, 0.0, 0.0, cur, alpha_tilde[rows])
    return cur


# The parallel kernels run each set's constraints, or the phases of cache tiles that share no
# particle, on all cores; their specification is the same (the layers never change the result).
solve_phases_parallel = solve_phases
solve_xpbd_parallel = solve_xpbd


def _largest_set(set_offsets):
    return int(np.diff(np.asarray(set_offsets)).max(initial=0))


def _scratch_size(set_offsets, layer_group_offsets):
    """Scratch rows the kernel needs: the largest set, or BLOCK rows per group of a layer of
    tiles solved side by side, whichever is more."""
    groups = np.diff(np.asarray(layer_group_offsets)).max(initial=0)
    return max(_largest_set(set_offsets), int(groups) * 256)  # BLOCK


def _measure_edges(cur, indices, first, count, at, length2, wa, wb):
    """Returns (length2, wa, wb), float64 copies with scratch rows at .. at+count-1 set to
    eps + |pb - pa|^2 and the inverse masses of constraints first .. first+count-1 (cur: the
    flat (n*4,) particle view)."""
    rows = np.asarray(cur, np.float64).reshape(-1, 4)
    length2, wa, wb = (np.array(x, np.float64) for x in (length2, wa, wb))
    pairs = np.asarray(indices)[first : first + count]
    h = rows[pairs[:, 1], :3] - rows[pairs[:, 0], :3]
    length2[at : at + count] = DISTANCE_EPSILON + np.einsum("ij,ij->i", h, h)
    wa[at : at + count] = rows[pairs[:, 0], 3]
    wb[at : at + count] = rows[pairs[:, 1], 3]
    return length2, wa, wb


def _move_ends(cur, indices, first, count, at, fa, fb):
    """Returns cur (flat float64 copy) with pa += h fa and pb -= h fb, h = pb - pa, for
    constraints first .. first+count-1 and their factors at scratch rows at .. at+count-1."""
    flat = np.array(cur, np.float64)
    rows = flat.reshape(-1, 4)
    pairs = np.asarray(indices)[first : first + count]
    a, b = pairs[:, 0], pairs[:, 1]
    h = rows[b, :3] - rows[a, :3]
    np.add.at(rows[:, :3], a, h * np.asarray(fa, np.float64)[at : at + count, None])
    np.add.at(rows[:, :3], b, -h * np.asarray(fb, np.float64)[at : at + count, None])
    return flat


def _edge_block(flat, indices, rest, constraint_stiffness, params, p, first, count, at, length2, wa, wb):
    """Returns flat (float64 copy) after NvCloth's update of constraints first .. first+count-1
    of phase p (one conflict-free block: solved at once)."""
    rows = np.array(flat, np.float64).reshape(-1, 4)
    k, m, lo, hi = np.asarray(params, np.float64)[p]
    span = slice(first, first + count)
    _solve_set(np.asarray(indices)[span], np.asarray(rest, np.float64)[span],
               np.asarray(constraint_stiffness, np.float64)[span], k, m, lo, hi, rows)
    return rows.reshape(-1)


def _xpbd_block(flat, indices, rest, alpha_tilde, params, p, first, count, at, length2, wa, wb):
    """Returns flat (float64 copy) after the XPBD update of constraints first .. first+count-1."""
    rows = np.array(flat, np.float64).reshape(-1, 4)
    span = slice(first, first + count)
    _solve_set(np.asarray(indices)[span], np.asarray(rest, np.float64)[span], 1.0, 1.0, 0.0, 0.0, 0.0, rows,
               np.asarray(alpha_tilde, np.float64)[span])
    return rows.reshape(-1)


def _edge_slack(rest, length2):
    """1 - r / sqrt(length2), 0 when r = 0."""
    return 1.0 - rest / np.sqrt(length2) if rest > 0 else 0.0


def _slack_over(rest, length2, denominator):
    """(1 - r / sqrt(length2), 0 when r = 0; 1 / denominator), in the arguments' precision (the
    kernel's float64 path gets both from one root and one division)."""
    er = 1 - rest / np.sqrt(length2) if rest > 0 else 0 * length2
    return er, 1 / denominator
