"""Bundled presets (TOML files under ``presets/<kind>/``) and typed settings from mappings.

A preset is named by its file stem (``cotton``) or given as a path to a TOML file. Settings
mappings (from presets, scene files or ``--set`` overrides) are applied onto frozen
dataclasses field by field: unknown keys are errors that list the allowed keys, and values
are converted to the field's type with an error naming the key.
"""

from __future__ import annotations

import dataclasses
import math
import re
import tomllib
import types
import typing
from pathlib import Path
from typing import Any

from clothtool.errors import PresetError
from clothtool.inputs import note_input
from clothtool.resources import data_dir

KINDS = ("cook", "material", "solver")


def preset_dir(kind: str) -> Path:
    return data_dir("presets") / kind


def available(kind: str) -> list[str]:
    """Names of the bundled presets of ``kind``, sorted."""
    folder = preset_dir(kind)
    return sorted(p.stem for p in folder.glob("*.toml")) if folder.is_dir() else []


def read_toml(path: Path, error=PresetError) -> dict[str, Any]:
    """Parse a TOML file; errors name the file, line and column."""
    note_input(path)
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise error(f"{path}: file not found; check the path") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise error(f"{path}: cannot be read ({exc}); check the file") from None
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise error(f"{path}: malformed TOML {_where(str(exc), text)}; fix the syntax there") from None


def _where(message: str, text: str) -> str:
    """tomllib's message with the offending line quoted (tomllib names line and column, or
    says "end of document", but not the key)."""
    lines = text.splitlines()
    match = re.search(r"\(at line (\d+), column \d+\)", message)
    if match:
        number = int(match.group(1))
    elif "end of document" in message:
        number = max(len(lines), 1)
        while number > 1 and not lines[number - 1].strip():
            number -= 1
    else:
        return f"({message})"
    reason = re.sub(r"\s*\(at [^)]*\)", "", message)
    source = lines[number - 1].strip() if 0 < number <= len(lines) else ""
    return f"at line {number}: {reason} in '{source}'"


def load_preset(kind: str, name: str) -> tuple[dict[str, Any], str]:
    """The mapping of preset ``name`` (bundled name or TOML path) and a label for messages."""
    looks_like_path = name.endswith(".toml") or "/" in name or "\\" in name
    if looks_like_path:
        path = Path(name)
        return read_toml(path), str(path)
    path = preset_dir(kind) / f"{name}.toml"
    if not path.is_file():
        names = ", ".join(available(kind)) or "none"
        raise PresetError(f"{kind} preset '{name}' not found; available {kind} presets: {names} (or give a .toml path)")
    return read_toml(path), f"{kind} preset '{name}'"


# --------------------------------------------------------------------------- typed settings
def _convert(value: Any, annotation: Any, where: str) -> Any:
    origin = typing.get_origin(annotation)
    args = typing.get_args(annotation)
    if origin in (typing.Union, types.UnionType):
        if value is None and type(None) in args:
            return None
        errors = []
        for arg in args:
            if arg is type(None):
                continue
            try:
                return _convert(value, arg, where)
            except PresetError as exc:
                errors.append(str(exc))
        raise PresetError(errors[0] if errors else f"{where}: invalid value {value!r}")
    if origin is tuple:
        if not isinstance(value, (list, tuple)):
            raise PresetError(f"{where}: expected a list, got {value!r}")
        if len(args) == 2 and args[1] is Ellipsis:
            return tuple(_convert(v, args[0], f"{where}[{i}]") for i, v in enumerate(value))
        if len(value) != len(args):
            raise PresetError(f"{where}: expected a list of {len(args)} values, got {len(value)}")
        return tuple(_convert(v, a, f"{where}[{i}]") for i, (v, a) in enumerate(zip(value, args)))
    if origin is typing.Literal:
        if value not in args:
            raise PresetError(f"{where}: {value!r} is not one of {', '.join(map(repr, args))}")
        return value
    if annotation is bool:
        if isinstance(value, bool):
            return value
        raise PresetError(f"{where}: expected true or false, got {value!r}")
    if annotation is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise PresetError(f"{where}: expected an integer, got {value!r}")
        return value
    if annotation is float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise PresetError(f"{where}: expected a number, got {value!r}")
        if math.isnan(value):
            raise PresetError(f"{where}: NaN is not a valid value")
        return float(value)
    if annotation is str:
        if not isinstance(value, str):
            raise PresetError(f"{where}: expected a string, got {value!r}")
        return value
    if dataclasses.is_dataclass(annotation):
        if not isinstance(value, dict):
            raise PresetError(f"{where}: expected a table, got {value!r}")
        return apply_mapping(annotation(), value, where)
    return value


def field_types(cls) -> dict[str, Any]:
    hints = typing.get_type_hints(cls)
    return {f.name: hints[f.name] for f in dataclasses.fields(cls) if f.init}


def apply_mapping(instance, mapping: dict[str, Any], where: str, skip: tuple[str, ...] = ()):
    """Return ``instance`` with the fields named in ``mapping`` replaced (typed, checked).

    Nested dataclass fields take nested tables, which update the nested instance.
    ``where`` names the source (file, preset, table) in error messages.
    """
    types_ = field_types(type(instance))
    allowed = [k for k in types_ if k not in skip]
    changes = {}
    for key, value in mapping.items():
        if key not in allowed:
            raise PresetError(f"{where}: unknown key '{key}'; allowed keys: {', '.join(allowed)}")
        annotation = types_[key]
        current = getattr(instance, key)
        if dataclasses.is_dataclass(current) and isinstance(value, dict):
            changes[key] = apply_mapping(current, value, f"{where}.{key}")
        else:
            changes[key] = _convert(value, annotation, f"{where}: key '{key}'")
    return dataclasses.replace(instance, **changes)


def parse_override_value(text: str) -> Any:
    """A ``--set KEY=VALUE`` value: TOML syntax (numbers, true/false, [lists], "strings"),
    falling back to a bare string."""
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        return text
