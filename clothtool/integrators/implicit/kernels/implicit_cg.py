"""Filtered, block-Jacobi preconditioned conjugate gradient on a 3x3-block sparse matrix.

Baraff & Witkin's modified PCG (section 5.3 of their paper): each particle i has a filter
S_i that removes its constrained directions; here a particle is either free (S = I) or fixed
(S = 0: pinned, or held by a motion constraint of radius 0), with a prescribed velocity
change of zero. The iteration starts at dv = 0 and keeps the residual and every search
direction filtered, so it solves A dv = rhs for the free particles while the fixed ones keep
dv = 0 exactly.

The preconditioner is the inverse of each particle's 3x3 diagonal block (block Jacobi),
exact for the stiff coupling within a particle and cheap to invert. The iteration stops when
the filtered residual's 2-norm falls to ``tolerance`` times the filtered right-hand side's
(or below an absolute floor), after ``max_iterations``, or if the matrix stops being
positive definite along a search direction (it cannot with the solver's Jacobians, which
are negative semi-definite). Vectors are (n,3) float64.

Dot products are summed per fixed chunk of particles and then over the chunks in order, so
the result does not depend on the number of threads.
"""

from __future__ import annotations

import math

from numba import prange
from numba.extending import register_jitable as jitable

from clothtool._jit import kernel

CHUNKS = 64  # rows of the partial-sum table (fixed, so sums do not depend on thread count)


@jitable
def _chunk(index, chunks, n):
    size = (n + chunks - 1) // chunks
    start = min(index * size, n)
    return start, min(start + size, n)


@jitable
def _row_product(row_offsets, columns, values, vector, i):
    y0 = 0.0
    y1 = 0.0
    y2 = 0.0
    for slot in range(row_offsets[i], row_offsets[i + 1]):
        j = columns[slot]
        a = vector[j, 0]
        b = vector[j, 1]
        c = vector[j, 2]
        y0 += values[slot, 0, 0] * a + values[slot, 0, 1] * b + values[slot, 0, 2] * c
        y1 += values[slot, 1, 0] * a + values[slot, 1, 1] * b + values[slot, 1, 2] * c
        y2 += values[slot, 2, 0] * a + values[slot, 2, 1] * b + values[slot, 2, 2] * c
    return y0, y1, y2


@kernel(parallel=True)
def block_matvec(row_offsets, columns, values, vector, out):
    """out = A vector for the block CSR matrix A (row_offsets (n+1,), columns, values (nnzb,3,3))."""
    for i in prange(row_offsets.shape[0] - 1):
        y0, y1, y2 = _row_product(row_offsets, columns, values, vector, i)
        out[i, 0] = y0
        out[i, 1] = y1
        out[i, 2] = y2


@kernel(parallel=True)
def block_jacobi(diagonal_slot, values, free, inverse):
    """inverse (n,3,3) out: the inverse of each free particle's diagonal block, 0 for the
    fixed ones (free == 0). A singular block gets 0 too (the particle then moves only through its
    neighbours, as in plain CG)."""
    for i in prange(diagonal_slot.shape[0]):
        for r in range(3):
            for c in range(3):
                inverse[i, r, c] = 0.0
        if free[i] == 0:
            continue
        s = diagonal_slot[i]
        a, b, c = values[s, 0, 0], values[s, 0, 1], values[s, 0, 2]
        d, e, f = values[s, 1, 0], values[s, 1, 1], values[s, 1, 2]
        g, h, k = values[s, 2, 0], values[s, 2, 1], values[s, 2, 2]
        c00 = e * k - f * h
        c01 = c * h - b * k
        c02 = b * f - c * e
        det = a * c00 + d * c01 + g * c02
        if det == 0.0 or not math.isfinite(det):
            continue
        inv = 1.0 / det
        inverse[i, 0, 0] = c00 * inv
        inverse[i, 0, 1] = c01 * inv
        inverse[i, 0, 2] = c02 * inv
        inverse[i, 1, 0] = (f * g - d * k) * inv
        inverse[i, 1, 1] = (a * k - c * g) * inv
        inverse[i, 1, 2] = (c * d - a * f) * inv
        inverse[i, 2, 0] = (d * h - e * g) * inv
        inverse[i, 2, 1] = (b * g - a * h) * inv
        inverse[i, 2, 2] = (a * e - b * d) * inv


@jitable
def _dot3(a, b, i):
    return a[i, 0] * b[i, 0] + a[i, 1] * b[i, 1] + a[i, 2] * b[i, 2]


@jitable
def _precondition(inverse, r, z, i):
    for k in range(3):
        z[i, k] = inverse[i, k, 0] * r[i, 0] + inverse[i, k, 1] * r[i, 1] + inverse[i, k, 2] * r[i, 2]


@kernel(parallel=True)
def filtered_pcg(row_offsets, columns, values, inverse, free, rhs, tolerance, absolute, max_iterations, dv, r, z, c, q,
                 partial):
    """Solve A dv = rhs for the free particles (free u8 (n,)), dv = 0 for the others.

    inverse (n,3,3): block-Jacobi preconditioner (``block_jacobi``); dv (n,3) out; r, z,
    c, q (n,3) and partial (CHUNKS,2): scratch. Stops when |S r| <= max(tolerance |S rhs|,
    absolute) (the absolute floor keeps a right-hand side that is zero but for rounding from
    costing iterations). Returns (iterations, |S r| / max(|S rhs|, absolute / tolerance))."""
    n = rhs.shape[0]
    chunks = partial.shape[0]
    for ch in prange(chunks):
        start, end = _chunk(ch, chunks, n)
        bb = 0.0
        rz = 0.0
        for i in range(start, end):
            keep = 1.0 if free[i] != 0 else 0.0
            for k in range(3):
                dv[i, k] = 0.0
                r[i, k] = keep * rhs[i, k]
            _precondition(inverse, r, z, i)
            for k in range(3):
                c[i, k] = z[i, k]
            bb += _dot3(r, r, i)
            rz += _dot3(r, z, i)
        partial[ch, 0] = bb
        partial[ch, 1] = rz
    bb = 0.0
    delta = 0.0
    for ch in range(chunks):
        bb += partial[ch, 0]
        delta += partial[ch, 1]
    scale = max(bb, (absolute / tolerance) ** 2) if tolerance > 0.0 else bb
    target = max(tolerance * tolerance * bb, absolute * absolute)
    if bb <= target:
        return 0, math.sqrt(bb / scale) if scale > 0.0 else 0.0
    rr = bb
    iterations = 0
    while iterations < max_iterations and rr > target:
        for ch in prange(chunks):
            start, end = _chunk(ch, chunks, n)
            cq = 0.0
            for i in range(start, end):
                if free[i] == 0:
                    q[i, 0] = 0.0
                    q[i, 1] = 0.0
                    q[i, 2] = 0.0
                    continue
                y0, y1, y2 = _row_product(row_offsets, columns, values, c, i)
                q[i, 0] = y0
                q[i, 1] = y1
                q[i, 2] = y2
                cq += _dot3(c, q, i)
            partial[ch, 0] = cq
        cq = 0.0
        for ch in range(chunks):
            cq += partial[ch, 0]
        if not cq > 0.0:
            break
        alpha = delta / cq
        iterations += 1
        for ch in prange(chunks):
            start, end = _chunk(ch, chunks, n)
            rr_part = 0.0
            rz_part = 0.0
            for i in range(start, end):
                for k in range(3):
                    dv[i, k] += alpha * c[i, k]
                    r[i, k] -= alpha * q[i, k]
                _precondition(inverse, r, z, i)
                rr_part += _dot3(r, r, i)
                rz_part += _dot3(r, z, i)
            partial[ch, 0] = rr_part
            partial[ch, 1] = rz_part
        rr = 0.0
        delta_new = 0.0
        for ch in range(chunks):
            rr += partial[ch, 0]
            delta_new += partial[ch, 1]
        if rr <= target or delta == 0.0:
            break
        beta = delta_new / delta
        delta = delta_new
        for ch in prange(chunks):
            start, end = _chunk(ch, chunks, n)
            for i in range(start, end):
                for k in range(3):
                    c[i, k] = z[i, k] + beta * c[i, k]
    return iterations, math.sqrt(rr / scale)
