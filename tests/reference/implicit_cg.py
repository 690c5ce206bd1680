"""Reference for clothtool.integrators.implicit.cg: the block sparse matrix through scipy, and
the filtered system's exact solution.

A filtered solve finds dv with dv_i = 0 for every constrained particle i and
(A dv - rhs)_i = 0 for every free one: the free particles' block of A solved against their
part of rhs (Baraff & Witkin's S-filtered system with zero constraint values).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse
import scipy.sparse.linalg


def to_scipy(row_offsets, columns, values) -> scipy.sparse.csr_matrix:
    """The (3n,3n) matrix of the block CSR arrays."""
    n = row_offsets.shape[0] - 1
    return scipy.sparse.bsr_matrix((values, columns, row_offsets), shape=(3 * n, 3 * n)).tocsr()


def block_matvec(row_offsets, columns, values, vector):
    return (to_scipy(row_offsets, columns, values) @ np.asarray(vector, np.float64).reshape(-1)).reshape(-1, 3)


def block_jacobi(diagonal_slot, values, free):
    """(n,3,3) inverse diagonal blocks of the free particles, zero for the others."""
    inverse = np.zeros((diagonal_slot.shape[0], 3, 3))
    mask = free != 0
    inverse[mask] = np.linalg.inv(values[diagonal_slot[mask]])
    return inverse


def filtered_pcg(row_offsets, columns, values, free, rhs):
    """(n,3) the exact solution of the filtered system (module docstring), which the
    kernel's iteration approaches."""
    matrix = to_scipy(row_offsets, columns, values)
    dofs = np.flatnonzero(np.repeat(free != 0, 3))
    dv = np.zeros(3 * free.shape[0])
    sub = matrix[dofs][:, dofs].tocsc()
    dv[dofs] = scipy.sparse.linalg.spsolve(sub, np.asarray(rhs, np.float64).reshape(-1)[dofs])
    return dv.reshape(-1, 3)
