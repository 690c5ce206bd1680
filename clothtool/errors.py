"""Error types raised by the library.

Every message is one line that names the file, the element (vertex/face index, TOML key,
collider name) and how to fix it; the command line prints it and exits with code 1 (2 for a UsageError).
"""


class ClothtoolError(Exception):
    """Base class for every error the library raises on bad input or a failed run."""


class MeshError(ClothtoolError):
    """A garment mesh that cannot be read or cooked."""


class FabricError(ClothtoolError):
    """A fabric that is malformed or inconsistent."""


class SceneError(ClothtoolError):
    """A scene file (or a track, collider or override inside it) that is invalid."""


class FormatError(ClothtoolError):
    """A file that is not in the format its name or header claims (or is truncated)."""


class PresetError(ClothtoolError):
    """A material or solver preset that is missing or has unknown/invalid keys."""


class UnstableError(ClothtoolError):
    """A bake that produced NaN/Inf or speeds beyond the limit."""


class UsageError(ClothtoolError):
    """A command asked for something it cannot do (an output format it cannot write, an
    output onto one of its inputs); the command line exits with code 2."""


class OutputClashError(UsageError):
    """An output path that names one of the command's input files."""


class ClothtoolWarning(UserWarning):
    """A problem that was repaired; `--strict` turns these into errors."""
