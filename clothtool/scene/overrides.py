"""``--set KEY=VALUE`` overrides applied to a scene's raw TOML tables before validation.

Keys are dotted paths (``solver.frequency``, ``cloth.skirt.material``,
``cloth.skirt.material.damping``); values use TOML syntax (``600``, ``true``, ``[1, 48]``,
``"denim"``) and fall back to a bare string (``denim``). A table given by a preset name as
a string (``material = "cotton"``) becomes ``{preset = "cotton"}`` when a key below it is set.
"""

from __future__ import annotations

import copy
import re

from clothtool.errors import SceneError
from clothtool.presets import parse_override_value

_KEY = re.compile(r"^[A-Za-z0-9_\-]+(\.[A-Za-z0-9_\-]+)*$")


def parse_override(text: str) -> tuple[list[str], object]:
    """'a.b.c=value' -> (['a', 'b', 'c'], value)."""
    if "=" not in text:
        raise SceneError(f"--set {text}: expected KEY=VALUE, e.g. --set solver.frequency=600")
    key, value = text.split("=", 1)
    key = key.strip()
    if not _KEY.match(key):
        raise SceneError(f"--set {text}: '{key}' is not a dotted key like solver.frequency")
    return key.split("."), parse_override_value(value.strip())


def apply_overrides(tables: dict, overrides: list[str]) -> dict:
    """A copy of ``tables`` with every override applied, in order."""
    result = copy.deepcopy(tables)
    for text in overrides:
        path, value = parse_override(text)
        node = result
        for depth, part in enumerate(path[:-1]):
            child = node.get(part)
            if child is None:
                child = node[part] = {}
            elif isinstance(child, str):
                child = node[part] = {"preset": child}
            elif not isinstance(child, dict):
                where = ".".join(path[: depth + 1])
                raise SceneError(f"--set {text}: '{where}' is a value, not a table, so it has no key '{path[depth + 1]}'")
            node = child
        node[path[-1]] = value
    return result
