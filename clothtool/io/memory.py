"""A cache writer that keeps frames in memory, for studies that compare bakes.

Unlike the file writers its memory grows with the frame count, so ``keep_every`` keeps
only every k-th frame (the last frame is always kept).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from clothtool.errors import ClothtoolError
from clothtool.io.cache import CacheHeader, FrameData


class MemoryCacheWriter:
    """The CacheWriter protocol into ``self.frames``: frame -> tuple of (n,3) float64 points."""

    def __init__(self, keep_every: int = 1):
        self.path = Path("memory")
        self.keep_every = keep_every
        self.header: CacheHeader | None = None
        self.frames: dict[int, tuple[np.ndarray, ...]] = {}
        self.committed = False
        self._last: FrameData | None = None

    def __enter__(self) -> "MemoryCacheWriter":
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        if self._last is not None:
            self._keep(self._last)

    def write_header(self, header: CacheHeader) -> None:
        self.header = header

    def _keep(self, frame: FrameData) -> None:
        self.frames[frame.frame] = tuple(np.array(p, np.float64) for p in frame.points)

    def write_frame(self, frame: FrameData) -> None:
        if self.header is None:
            raise ClothtoolError("memory cache: write_frame called before write_header")
        if (frame.frame - self.header.start_frame) % self.keep_every == 0:
            self._keep(frame)
        self._last = frame

    def commit(self) -> None:
        self.committed = True
