"""Where the bundled presets and format specs live.

In a wheel they are packaged as ``clothtool/_data/{presets,formats}``; in a source checkout
(or an editable install) they are the top-level ``presets/`` and ``formats/`` folders.
"""

from __future__ import annotations

from pathlib import Path

_PACKAGE_DIR = Path(__file__).resolve().parent


def data_dir(name: str) -> Path:
    """Return the directory of bundled data ``name`` ("presets" or "formats")."""
    for candidate in (_PACKAGE_DIR / "_data" / name, _PACKAGE_DIR.parent / name):
        if candidate.is_dir():
            return candidate
    raise FileNotFoundError(
        f"clothtool installation is incomplete: no '{name}' directory next to {_PACKAGE_DIR}; "
        "reinstall clothtool"
    )
