"""Per-frame and per-iteration timing shared by the stages of one cloth."""

from __future__ import annotations

import dataclasses

from clothtool.solver.frame import IterationTerms


@dataclasses.dataclass(frozen=True)
class FramePlan:
    """One frame of one cloth: ``iterations`` steps of length ``h`` from ``time``."""

    frame: int
    time: float  # seconds at the start of the frame
    frame_dt: float
    iterations: int
    h: float  # iteration length in seconds
    exponent: float  # stiffness_frequency * h: stiffness-frequency steps per iteration


@dataclasses.dataclass(frozen=True)
class Iteration:
    """One solver iteration of one cloth."""

    index: int  # 0 .. iterations-1 within the frame
    alpha0: float  # fraction of the frame at the iteration's start
    alpha1: float  # ... and end
    scale: float  # velocity scale: damping over h, times h / h_prev
    terms: IterationTerms | None  # frame motion terms, None when the frame does not move
