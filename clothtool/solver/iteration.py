"""Per-frame and per-iteration timing shared by the stages of one cloth."""

from __future__ import annotations

import dataclasses
import functools

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
    end_time: float | None = None  # seconds at the frame's end, exactly (default time + frame_dt)

    @staticmethod
    def iterations_for(frame_dt: float, frequency: float) -> int:
        """Iterations of a frame of ``frame_dt`` seconds at ``frequency`` Hz (at least one)."""
        return max(1, int(frame_dt * frequency + 0.5))

    @property
    def end(self) -> float:
        """Seconds at the frame's end."""
        return self.end_time if self.end_time is not None else self.time + self.frame_dt

    def iteration_end(self, index: int) -> float:
        """Seconds at the end of iteration ``index``; the last one ends exactly at end_time,
        so a track key at the frame's time is sampled at the key, not a rounding error past it."""
        if index + 1 == self.iterations:
            return self.end
        return self.time + iteration_offsets(self.frame_dt, self.iterations)[index]

    def iteration_ends(self) -> list[float]:
        """``iteration_end`` of every iteration."""
        return [self.time + offset for offset in iteration_offsets(self.frame_dt, self.iterations)] + [self.end]


@functools.lru_cache(maxsize=16)
def iteration_offsets(frame_dt: float, iterations: int) -> tuple[float, ...]:
    """Seconds from a frame's start to the end of each of its iterations but the last (the
    same for every frame of a bake): an iteration ends at the frame's start plus its offset."""
    return tuple(frame_dt * (index + 1) / iterations for index in range(iterations - 1))


@dataclasses.dataclass(frozen=True)
class Iteration:
    """One solver iteration of one cloth."""

    index: int  # 0 .. iterations-1 within the frame
    alpha0: float  # fraction of the frame at the iteration's start
    alpha1: float  # ... and end
    scale: float  # velocity scale: damping over h, times h / h_prev
    terms: IterationTerms | None  # frame motion terms, None when the frame does not move
