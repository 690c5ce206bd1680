"""3-vectors as tuples of floats for the implicit integrator's kernels: they live in
registers, so kernels do small-vector algebra without allocating.

The functions are ``register_jitable``: compiled into each kernel that calls them (with that
kernel's options from ``clothtool._jit``), plain Python elsewhere.
"""

from __future__ import annotations

import math

from numba.extending import register_jitable as jitable


@jitable
def row(a, i):
    """Row i of an (n,3) array as a tuple."""
    return (a[i, 0], a[i, 1], a[i, 2])


@jitable
def add(a, b):
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


@jitable
def sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


@jitable
def axpy(s, a, b):
    """s a + b"""
    return (s * a[0] + b[0], s * a[1] + b[1], s * a[2] + b[2])


@jitable
def scale(s, a):
    return (s * a[0], s * a[1], s * a[2])


@jitable
def dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@jitable
def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


@jitable
def norm(a):
    return math.sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2])


@jitable
def add_row(out, i, s, a):
    """out[i] += s a"""
    out[i, 0] += s * a[0]
    out[i, 1] += s * a[1]
    out[i, 2] += s * a[2]


@jitable
def set_row(out, i, a):
    out[i, 0] = a[0]
    out[i, 1] = a[1]
    out[i, 2] = a[2]
