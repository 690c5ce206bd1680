"""Write outputs atomically: into a temporary file beside the target, renamed on success.

A failed or interrupted write never leaves a half-written file under the target's name.
"""

from __future__ import annotations

import contextlib
import os
from pathlib import Path

from clothtool.errors import ClothtoolError


def check_output_path(path: str | os.PathLike) -> Path:
    """Fail early, with a clear message, when ``path`` cannot be written."""
    path = Path(path)
    parent = path.parent if str(path.parent) else Path(".")
    if not parent.is_dir():
        raise ClothtoolError(f"{path}: output directory '{parent}' does not exist; create it first")
    if path.is_dir():
        raise ClothtoolError(f"{path}: is a directory; give a file name")
    return path


def temporary_sibling(path: Path, tag: str = "tmp") -> Path:
    return path.with_name(f".{path.name}.{tag}-{os.getpid()}")


@contextlib.contextmanager
def atomic_output(path: str | os.PathLike):
    """Yield a temporary path to write; on success rename it to ``path``, else delete it."""
    path = check_output_path(path)
    tmp = temporary_sibling(path)
    try:
        yield tmp
        os.replace(tmp, path)
    finally:
        with contextlib.suppress(FileNotFoundError):
            tmp.unlink()
