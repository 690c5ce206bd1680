"""Write outputs atomically: into a temporary file beside the target, renamed on success.

A failed or interrupted write never leaves a half-written file under the target's name.

Temporary files are named after the process writing them,
``.NAME.clothtool-tmp.PID.START.SPACE[.SUFFIX]``: its pid, its start time (clock ticks
after boot, so a reused pid is told apart) and SPACE, a hash of the kernel's boot id and the
pid namespace (so the pid is only judged where it means the same process). A process killed
with ``kill -9`` cannot clean up after itself: the next clothtool run that opens an output in
the same folder removes the temporaries whose process is gone (``remove_stale_temporaries``).
"""

from __future__ import annotations

import contextlib
import errno
import functools
import hashlib
import os
import re
from pathlib import Path

from clothtool.errors import ClothtoolError

_MARK = "clothtool-tmp"
_TEMPORARY = re.compile(rf"\.(?P<target>.+)\.{_MARK}\.(?P<pid>\d+)\.(?P<start>\d+)\.(?P<space>[0-9a-f]{{8}})(?:\.[A-Za-z0-9]+)?\Z")
# Before process-tagged names, clothtool wrote ".NAME.tmp-PID[.SUFFIX]": removed once that pid is unused.
_LEGACY_TEMPORARY = re.compile(
    r"\.(?P<target>.+\.(?:h5|hdf5|usd|usda|usdc|json|html|csv|svg|png))\.tmp-(?P<pid>\d+)(?:\.[A-Za-z0-9]+)?\Z"
)


def check_output_path(path: str | os.PathLike) -> Path:
    """Fail early, with a clear message, when ``path`` cannot be written."""
    path = Path(path)
    parent = path.parent if str(path.parent) else Path(".")
    if not parent.is_dir():
        raise ClothtoolError(f"{path}: output directory '{parent}' does not exist; create it first")
    if path.is_dir():
        raise ClothtoolError(f"{path}: is a directory; give a file name")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise ClothtoolError(f"{path}: output directory '{parent}' is not writable; choose another directory or fix its permissions")
    return path


def write_error(path, exc: BaseException, doing: str) -> ClothtoolError:
    """One line for an OSError (or an h5py/USD error carrying its text) met while ``doing``."""
    code = getattr(exc, "errno", None)
    text = " ".join(str(exc).split())
    if code == errno.ENOSPC or "No space left on device" in text:
        return ClothtoolError(f"{path}: disk full while {doing} (No space left on device); free space or choose another directory")
    if code == errno.EDQUOT or "Disk quota exceeded" in text:
        return ClothtoolError(f"{path}: disk quota exceeded while {doing}; free space or choose another directory")
    if code in (errno.EACCES, errno.EPERM, errno.EROFS) or "Permission denied" in text or "Read-only file system" in text:
        reason = "read-only file system" if code == errno.EROFS or "Read-only" in text else "permission denied"
        return ClothtoolError(f"{path}: cannot write while {doing} ({reason}); choose a writable directory")
    detail = os.strerror(code) if isinstance(code, int) and code > 0 else (text.splitlines()[0][:200] if text else type(exc).__name__)
    return ClothtoolError(f"{path}: cannot write while {doing} ({detail}); check the disk and the directory")


# ---------------------------------------------------------------------------------------------
# Temporary names that say which process writes them.


def _proc_start_ticks(pid: int) -> int | None:
    """The process's start time in clock ticks after boot (Linux /proc), or None if it is gone."""
    try:
        with open(f"/proc/{pid}/stat", "rb") as stat:
            fields = stat.read().rsplit(b")", 1)[1].split()
    except (FileNotFoundError, ProcessLookupError, IndexError):
        return None
    return int(fields[19])  # field 22 of proc(5), counted from field 3 after the command name


@functools.lru_cache(maxsize=None)
def _pid_space() -> str:
    """8 hex digits naming where a pid means one process: this boot of the kernel, this pid namespace."""
    parts = []
    with contextlib.suppress(OSError):
        parts.append(Path("/proc/sys/kernel/random/boot_id").read_text().strip())
    with contextlib.suppress(OSError):
        parts.append(os.readlink("/proc/self/ns/pid"))
    return hashlib.sha256("|".join(parts).encode()).hexdigest()[:8]


@functools.lru_cache(maxsize=None)
def _has_proc() -> bool:
    return Path(f"/proc/{os.getpid()}/stat").is_file()


def _owner_tag() -> str:
    pid = os.getpid()
    start = _proc_start_ticks(pid) if _has_proc() else 0
    return f"{pid}.{start or 0}.{_pid_space()}"


def _owner_is_gone(pid: int, start: int) -> bool:
    if _has_proc():
        return _proc_start_ticks(pid) != start  # gone, or the pid now belongs to a newer process
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return True
    except PermissionError:
        return False
    return False


def _legacy_owner_is_gone(pid: int) -> bool:
    # No start time in the name: a pid in use (by anyone) keeps the file.
    return _proc_start_ticks(pid) is None if _has_proc() else _owner_is_gone(pid, -1)


def is_stale_temporary(name: str) -> bool:
    """True for a clothtool temporary file name whose writing process no longer runs."""
    match = _TEMPORARY.match(name)
    if match:
        return match["space"] == _pid_space() and _owner_is_gone(int(match["pid"]), int(match["start"]))
    match = _LEGACY_TEMPORARY.match(name)
    return bool(match) and _legacy_owner_is_gone(int(match["pid"]))


def remove_stale_temporaries(folder: str | os.PathLike) -> list[Path]:
    """Remove the temporaries that killed clothtool processes left in ``folder``; return them.

    Only names of clothtool's own pattern are touched, and only when their process is gone
    (files of another boot, host or pid namespace are left alone: their pid means nothing here).
    """
    removed = []
    try:
        entries = list(os.scandir(folder))
    except OSError:
        return removed
    for entry in entries:
        if not entry.name.startswith(".") or not entry.is_file(follow_symlinks=False) or not is_stale_temporary(entry.name):
            continue
        with contextlib.suppress(FileNotFoundError, PermissionError):
            os.unlink(entry.path)
            removed.append(Path(entry.path))
    return removed


def temporary_sibling(path: Path, keep_suffix: bool = False) -> Path:
    """A temporary name beside ``path`` owned by this process (``keep_suffix``: end with
    ``path``'s suffix, for libraries that pick the format by it). Opening an output is when
    the folder's stale temporaries are removed."""
    remove_stale_temporaries(path.parent if str(path.parent) else ".")
    name = f".{path.name}.{_MARK}.{_owner_tag()}"
    return path.with_name(name + (path.suffix if keep_suffix else ""))


def remove_quietly(path: Path) -> None:
    """Delete ``path`` if it is there; a file that cannot be removed must not hide the real error."""
    with contextlib.suppress(OSError):
        path.unlink()


@contextlib.contextmanager
def atomic_output(path: str | os.PathLike, doing: str = "writing the file"):
    """Yield a temporary path to write; on success rename it to ``path``, else delete it.

    An OSError while writing becomes one ClothtoolError line (disk full, read-only, ...).
    """
    path = check_output_path(path)
    tmp = temporary_sibling(path)
    try:
        try:
            yield tmp
            os.replace(tmp, path)
        except OSError as exc:
            raise write_error(path, exc, doing) from None
    finally:
        remove_quietly(tmp)
