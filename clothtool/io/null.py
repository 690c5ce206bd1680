"""A cache writer that writes nothing: benchmarks time the solver, not the disk.

``clothtool bake SCENE -o null`` (or ``-o /dev/null``) selects it.
"""

from __future__ import annotations

import os
from pathlib import Path

from clothtool.errors import ClothtoolError
from clothtool.io.cache import CacheHeader, CacheOptions, FrameData


class NullCacheWriter:
    """The CacheWriter protocol with every write discarded; only counts frames."""

    def __init__(self, path: Path | None = None, options: CacheOptions = CacheOptions()):
        self.path = Path(os.devnull)
        self.header: CacheHeader | None = None
        self.frames_written = 0

    def __enter__(self) -> "NullCacheWriter":
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        pass

    def write_header(self, header: CacheHeader) -> None:
        self.header = header

    # The bake builds no frame for a writer that discards frames (world points, velocities,
    # collider transforms): it calls skip_frame instead of write_frame.
    discards_frames = True

    def write_frame(self, frame: FrameData) -> None:
        self.skip_frame(frame.frame)

    def skip_frame(self, frame: int) -> None:
        if self.header is None:
            raise ClothtoolError(f"{self.path}: write_frame called before write_header")
        self.frames_written += 1

    def commit(self) -> None:
        pass
