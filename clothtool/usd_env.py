"""How clothtool runs pxr: import this module before ``pxr`` is first used. A neutral module
(standard library only): the scene's stage reader and io's USD readers and writer share it.

* Crate files are memory-mapped by default. Under an address-space limit (``ulimit -v``,
  as some farms set) mapping a multi-gigabyte cache fails and pxr then crashes; reading
  with pread instead keeps the address space small, at no measurable cost for our
  streaming reads. The setting is read once, when the first crate file opens.
* pxr reports composition problems (an unresolved reference, a missing sublayer) as
  multi-line warnings straight on the process's stderr, outside Python. ``quiet_stderr``
  holds them back for the length of a call, so that readers can turn them into one line.
"""

from __future__ import annotations

import contextlib
import os
import resource
import sys
import tempfile


def _address_space_limited() -> bool:
    soft, _ = resource.getrlimit(resource.RLIMIT_AS)
    return soft != resource.RLIM_INFINITY


if _address_space_limited():
    os.environ.setdefault("USDC_USE_PREAD", "1")


@contextlib.contextmanager
def quiet_stderr():
    """Redirect the process's native stderr (file descriptor 2) for the block; yields a
    list that holds what was written once the block ends."""
    captured: list[str] = []
    sys.stderr.flush()
    saved = os.dup(2)
    with tempfile.TemporaryFile(mode="w+b") as sink:
        os.dup2(sink.fileno(), 2)
        try:
            yield captured
        finally:
            sys.stderr.flush()
            os.dup2(saved, 2)
            os.close(saved)
            sink.seek(0)
            captured.append(sink.read().decode("utf-8", "replace"))
