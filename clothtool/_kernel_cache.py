"""Where compiled kernels are cached on disk, and under which key.

numba's own cache sits beside the sources (or in a directory named after their absolute
path) and checks only the kernel's own file: a clone at another path recompiles everything, a
read-only install with no writable home cannot cache at all (numba then refuses to compile
``cache=True`` functions), and an edit to code that kernels inline from another file
(``clothtool._simd``, ``register_jitable`` helpers, module constants) is not seen. Here:

* the cache lives in a user cache directory: ``$CLOTHTOOL_CACHE_DIR``, else the platform's
  user cache directory (``$XDG_CACHE_HOME`` or ``~/.cache`` on Linux) + ``clothtool/numba``;
* inside it, one sub-directory per *key*: a hash of numba's and llvmlite's versions, the
  Python version, the codegen target (triple, CPU name and features) and the contents of
  every ``clothtool/**/*.py`` (package-relative names, never absolute paths). Any edit to any
  source gives a new key, so stale code cannot be loaded; a second clone at another path with
  the same contents and cache directory loads everything. Old key directories are left
  behind; ``clothtool warmup --clear`` removes the whole cache;
* when no cache directory can be created or written, kernels are compiled in memory for this
  process and one ``KernelCacheWarning`` says so (the CLI prints it as one line).
"""

from __future__ import annotations

import functools
import hashlib
import inspect
import os
import shutil
import sys
import tempfile
import warnings
from pathlib import Path

from numba.core.caching import CompileResultCacheImpl, FunctionCache, _CacheLocator

import clothtool

CACHE_DIR_ENV = "CLOTHTOOL_CACHE_DIR"
PACKAGE_ROOT = Path(clothtool.__file__).resolve().parent


class KernelCacheWarning(UserWarning):
    """The kernel cache cannot be used in this process; kernels are compiled in memory."""


def cache_root() -> Path:
    """The cache directory holding every key's sub-directory (it may not exist yet).

    Raises OSError when no location can be derived (no HOME and no explicit setting)."""
    explicit = os.environ.get(CACHE_DIR_ENV)
    if explicit:
        return Path(explicit).expanduser()
    if sys.platform == "win32":
        base = Path(os.environ.get("LOCALAPPDATA") or Path.home() / "AppData" / "Local")
    elif sys.platform == "darwin":
        base = Path.home() / "Library" / "Caches"
    else:
        xdg = os.environ.get("XDG_CACHE_HOME")
        # The XDG spec says a relative value is invalid and must be ignored.
        base = Path(xdg) if xdg and os.path.isabs(xdg) else Path.home() / ".cache"
    return base / "clothtool" / "numba"


@functools.lru_cache(maxsize=None)
def source_digest() -> str:
    """sha256 over every ``clothtool/**/*.py``: package-relative name and contents (a few ms,
    once per process). Kernels inline code and freeze globals from other modules, so every
    source counts, not only the kernel's own file."""
    digest = hashlib.sha256()
    for path in sorted(PACKAGE_ROOT.rglob("*.py"), key=lambda p: p.relative_to(PACKAGE_ROOT).as_posix()):
        digest.update(path.relative_to(PACKAGE_ROOT).as_posix().encode() + b"\0")
        digest.update(path.read_bytes() + b"\0")
    return digest.hexdigest()


@functools.lru_cache(maxsize=None)
def toolchain() -> tuple:
    """What else decides the compiled code: compiler versions, Python, the codegen target."""
    import llvmlite
    import numba
    from numba.core.registry import cpu_target

    triple, cpu_name, cpu_features = cpu_target.target_context.codegen().magic_tuple()
    return (numba.__version__, llvmlite.__version__, sys.version, sys.implementation.cache_tag, triple, cpu_name,
            cpu_features)


@functools.lru_cache(maxsize=None)
def cache_key() -> str:
    digest = hashlib.sha256(repr(toolchain()).encode() + b"\0" + source_digest().encode())
    return digest.hexdigest()[:20]


def key_directory() -> Path:
    return cache_root() / cache_key()


@functools.lru_cache(maxsize=None)
def usable_key_directory() -> Path | None:
    """The key directory, created and proven writable; None (after one KernelCacheWarning)
    when that fails, e.g. a read-only install whose HOME cannot be written."""
    try:
        directory = key_directory()
        directory.mkdir(parents=True, exist_ok=True)
        tempfile.TemporaryFile(dir=directory).close()
    except (OSError, RuntimeError) as exc:  # RuntimeError: Path.home() with no HOME and no passwd entry
        reason = exc.strerror if isinstance(exc, OSError) and exc.strerror else str(exc)
        if isinstance(exc, OSError) and exc.filename:
            reason = f"{reason}: {exc.filename}"
        warnings.warn(
            f"kernel cache disabled ({reason}); kernels are compiled in memory for this run; "
            f"set {CACHE_DIR_ENV} to a writable directory to keep them",
            KernelCacheWarning,
            stacklevel=2,
        )
        return None
    return directory


def _relative_source_dir(py_file: str) -> tuple[str, ...]:
    """The cache sub-directory of a kernel defined in ``py_file``: its package-relative folder
    for clothtool's own modules; for code outside the package (scripts, tests), its folder's
    name plus a hash of the folder's absolute path, as numba does."""
    path = Path(py_file).resolve()
    try:
        return ("clothtool",) + path.parent.relative_to(PACKAGE_ROOT).parts
    except ValueError:
        return ("external", f"{path.parent.name}_{hashlib.sha1(str(path.parent).encode()).hexdigest()[:16]}")


class PackageCacheLocator(_CacheLocator):
    """Puts a kernel's cache files under the key directory, at the source's package-relative
    folder. The source stamp numba checks is the content digest of the whole package (the key
    directory already depends on it; the stamp makes the rule hold even for a reused
    directory), so neither paths nor modification times ever count."""

    def __init__(self, py_func, py_file: str, directory: Path):
        self._py_file = py_file
        self._lineno = py_func.__code__.co_firstlineno
        self._inside_package = _relative_source_dir(py_file)[0] == "clothtool"
        self._cache_path = str(directory.joinpath(*_relative_source_dir(py_file)))

    def get_cache_path(self) -> str:
        return self._cache_path

    def get_source_stamp(self) -> str:
        if self._inside_package:
            return source_digest()
        return hashlib.sha256(Path(self._py_file).read_bytes()).hexdigest()

    def get_disambiguator(self) -> str:
        return str(self._lineno)

    @classmethod
    def from_function(cls, py_func, py_file: str):
        directory = usable_key_directory()
        if directory is None or not os.path.exists(py_file):
            return None
        return cls(py_func, py_file, directory)


class _PackageCacheImpl(CompileResultCacheImpl):
    _locator_classes = [PackageCacheLocator]  # type: ignore[list-item]  # numba types the list as list[type[object]]


class PackageFunctionCache(FunctionCache):
    """numba's per-function cache (index + data files, overloads keyed by signature and
    codegen) with the locator above."""

    _impl_class = _PackageCacheImpl


def attach_cache(dispatcher) -> None:
    """Give a freshly made numba dispatcher the package cache, or leave it uncached (compiled
    in memory) when the cache directory is unusable. The dispatcher stores its cache in
    ``_cache``, which is what numba's own ``enable_caching`` sets."""
    if usable_key_directory() is None or not os.path.exists(inspect.getfile(dispatcher.py_func)):
        return  # no cache directory, or a function typed at a prompt (no source file)
    dispatcher._cache = PackageFunctionCache(dispatcher.py_func)


def clear_cache() -> Path:
    """Remove the whole cache directory (every key's sub-directory); returns its path."""
    root = cache_root()
    if root.exists():
        shutil.rmtree(root)
    return root
