"""Which files a command read, so that none of its outputs lands on one of them.

``clothtool cook x.obj -o x.obj`` or a bake whose output is the fabric its scene reads would
destroy the input when the finished output is renamed into place. Every reader notes the
files it opens with ``note_input``; a command collects them inside ``recording_inputs()``
and calls ``refuse_output_onto_input`` for each output before writing anything.

The record is a context variable, so readers need no extra parameter and library callers
that never record pay nothing.
"""

from __future__ import annotations

import contextlib
import contextvars
import os
from pathlib import Path

from clothtool.errors import OutputClashError

_recorded: contextvars.ContextVar[list[Path] | None] = contextvars.ContextVar("clothtool_inputs", default=None)


def note_input(path: str | os.PathLike) -> None:
    """Record that the running command reads ``path`` (no-op outside ``recording_inputs``)."""
    inputs = _recorded.get()
    if inputs is not None:
        inputs.append(Path(path))


@contextlib.contextmanager
def recording_inputs():
    """Yield the list that collects every file noted while the block runs."""
    inputs: list[Path] = []
    token = _recorded.set(inputs)
    try:
        yield inputs
    finally:
        _recorded.reset(token)


def _same_file(a: Path, b: Path) -> bool:
    """True when ``a`` and ``b`` name one file: the same resolved path, or the same inode
    (a hard link or a symbolic link to it)."""
    if a.resolve() == b.resolve():
        return True
    try:
        return os.path.samefile(a, b)
    except OSError:  # one of them does not exist: it cannot be the other
        return False


def refuse_output_onto_input(output: str | os.PathLike, inputs, what: str = "output") -> None:
    """Raise OutputClashError (a usage error) when ``output`` is one of ``inputs``."""
    output = Path(output)
    for source in inputs:
        if _same_file(output, Path(source)):
            raise OutputClashError(
                f"{output}: the {what} is the input file '{source}', which writing would destroy; "
                "choose another output path"
            )
