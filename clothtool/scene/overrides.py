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
from clothtool.presets import did_you_mean, parse_override_value

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


class Named:
    """A schema level whose keys are names the scene defines (``cloth.<name>``), each with
    the schema ``entry``."""

    def __init__(self, entry):
        self.entry = entry


def _closest_name(name: str, section: str, names: list[str]) -> str:
    if not names:
        return f"it has no [{section}.*] tables"
    suggestion = did_you_mean(name, names)
    return suggestion if suggestion.startswith("did you") else f"its [{section}.*] tables: {', '.join(names)}"


def check_override_keys(tables: dict, overrides: list[str], schema: dict) -> None:
    """Refuse an override whose key the scene format does not have, blaming the command
    line (not the scene file) and suggesting the closest key.

    ``schema`` maps each key to its sub-schema: a dict, a ``Named``, or None for a value
    (below a value nothing is checked here; the scene's own validation takes over).
    """
    for text in overrides:
        path, _ = parse_override(text)
        level, node = schema, tables
        for depth, part in enumerate(path):
            where = ".".join(path[:depth]) or "the scene"
            if isinstance(level, Named):
                names = list(node) if isinstance(node, dict) else []
                if part not in names:
                    section = path[depth - 1]
                    raise SceneError(
                        f"--set {text}: the scene has no [{section}.{part}]; "
                        + _closest_name(part, section, names)
                    )
                level = level.entry
            elif isinstance(level, dict):
                if part not in level:
                    raise SceneError(f"--set {text}: unknown key '{part}' in {where}; {did_you_mean(part, list(level))}")
                level = level[part]
            else:
                break
            node = node.get(part) if isinstance(node, dict) else None


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
