"""StageProfiler: wall time per solver stage, with JIT compile time kept apart.

Stages are timed with ``time.perf_counter`` around each call; the timer objects are reused
so that timing a stage costs well under a microsecond.
"""

from __future__ import annotations

import time

JIT_STAGE = "jit warm-up"  # compiled once before the first frame; reported apart, never per frame


class _Timer:
    __slots__ = ("profiler", "name", "start")

    def __init__(self, profiler: "StageProfiler", name: str):
        self.profiler = profiler
        self.name = name
        self.start = 0.0

    def __enter__(self):
        self.start = time.perf_counter()
        return self

    def __exit__(self, exc_type, exc, tb):
        self.profiler.add(self.name, time.perf_counter() - self.start)
        return False


class StageProfiler:
    """Accumulates seconds and call counts per stage name, in first-use order."""

    def __init__(self) -> None:
        self.seconds: dict[str, float] = {}
        self.calls: dict[str, int] = {}
        self._timers: dict[str, _Timer] = {}

    def stage(self, name: str) -> _Timer:
        timer = self._timers.get(name)
        if timer is None:
            timer = self._timers[name] = _Timer(self, name)
            self.seconds.setdefault(name, 0.0)
            self.calls.setdefault(name, 0)
        return timer

    def add(self, name: str, seconds: float) -> None:
        self.seconds[name] = self.seconds.get(name, 0.0) + seconds
        self.calls[name] = self.calls.get(name, 0) + 1

    def table(self, frames: int, exclude: tuple[str, ...] = (JIT_STAGE,)) -> list[dict]:
        """Rows (stage, total_s, per_frame_ms, share, calls); share is of the simulation time,
        i.e. excluding JIT warm-up, which is reported apart."""
        total = sum(v for k, v in self.seconds.items() if k not in exclude) or 1.0
        rows = []
        for name, seconds in self.seconds.items():
            rows.append(
                {
                    "stage": name,
                    "total_s": seconds,
                    "per_frame_ms": 1000.0 * seconds / max(frames, 1),
                    "share": 0.0 if name in exclude else seconds / total,
                    "calls": self.calls.get(name, 0),
                }
            )
        return rows


def format_profile(rows: list[dict]) -> str:
    lines = [f"{'stage':<14} {'total s':>9} {'ms/frame':>9} {'share':>7} {'calls':>8}"]
    for row in rows:
        jit = row["stage"] == JIT_STAGE
        share = "-" if jit else f"{100 * row['share']:.1f}%"
        per_frame = "-" if jit else f"{row['per_frame_ms']:.3f}"
        lines.append(f"{row['stage']:<14} {row['total_s']:>9.3f} {per_frame:>9} {share:>7} {row['calls']:>8}")
    return "\n".join(lines)
