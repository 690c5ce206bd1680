"""NvCloth's log-space stiffness (see the seed's "Log Stiffness" section).

A user stiffness k in [0,1] removes the fraction k of a constraint error per step of the
stiffness frequency f. Stored as log2(1 - k) (or -FLT_MAX_EXP when k = 1), it converts to an
iteration of length dt as k_dt = 1 - 2^(log2(1 - k) * f * dt), so the error left after one
second is the same at every solver frequency. NvCloth applies the same transform to the
stiffness multiplier (whose log is log2(multiplier)), tethers, motion constraints,
self-collision and the drag and lift coefficients; so do we.
"""

from __future__ import annotations

import math

import numpy as np

FLT_MAX_EXP = 128.0


def safe_log2(x: float) -> float:
    """log2(x), or -FLT_MAX_EXP for x <= 0 (NvCloth's safeLog2)."""
    return math.log2(x) if x > 0.0 else -FLT_MAX_EXP


def log_stiffness(k: float) -> float:
    """Stiffness in [0,1] to NvCloth's stored form log2(1 - k)."""
    return safe_log2(1.0 - k)


def stiffness_exponent(stiffness_frequency: float, dt: float) -> float:
    """Number of stiffness-frequency steps in one iteration of length dt."""
    return stiffness_frequency * dt


def per_iteration(log_k: float, exponent: float) -> np.float32:
    """Stiffness for one iteration: 1 - 2^(log_k * exponent), as float32 (what kernels use)."""
    return np.float32(1.0 - 2.0 ** (log_k * exponent))


def iteration_stiffness(k: float, stiffness_frequency: float, dt: float) -> np.float32:
    return per_iteration(log_stiffness(k), stiffness_exponent(stiffness_frequency, dt))


def iteration_multiplier(multiplier: float, stiffness_frequency: float, dt: float) -> np.float32:
    """The stiffness multiplier's per-iteration form: 1 - multiplier^(f dt) (0 = neutral)."""
    return per_iteration(safe_log2(multiplier), stiffness_exponent(stiffness_frequency, dt))


def limit_term(limit: float) -> np.float32:
    """Compression/stretch limit as the slack threshold 1 - 1/limit (negative: compression)."""
    return np.float32(1.0 - 1.0 / limit)


def damping_scale(damping: float, stiffness_frequency: float, dt: float) -> float:
    """Fraction of velocity kept over one iteration: (1 - damping)^(f dt)."""
    return 2.0 ** (log_stiffness(damping) * stiffness_exponent(stiffness_frequency, dt))
