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
import stat
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


# TOML inputs (presets, scenes) are hand-written settings: anything bigger is not one, and
# reading /dev/zero or a multi-gigabyte file must not run the machine out of memory.
MAX_TOML_BYTES = 16 << 20
MAX_PRESET_BYTES = 1 << 20


def read_toml(path: Path, error=PresetError, max_bytes: int = MAX_TOML_BYTES, quote: bool = True) -> dict[str, Any]:
    """Parse a TOML file; errors name the file, line and column (and quote the line when
    ``quote``: never for a file named by someone else, which may hold anything).

    The file must be a regular file of at most ``max_bytes``: checked before reading.
    """
    note_input(path)
    try:
        info = path.stat()
    except FileNotFoundError:
        raise error(f"{path}: file not found; check the path") from None
    except OSError as exc:
        raise error(f"{path}: cannot be read ({exc.strerror or type(exc).__name__}); check the path") from None
    if not stat.S_ISREG(info.st_mode):
        raise error(f"{path}: is not a regular file; give the path of a .toml file")
    if info.st_size > max_bytes:
        raise error(f"{path}: is {info.st_size:,} bytes, more than the {max_bytes:,} a settings file may have; check the path")
    try:
        with path.open("rb") as handle:
            data = handle.read(max_bytes + 1)  # the file may grow between stat and read
        if len(data) > max_bytes:
            raise error(f"{path}: is more than the {max_bytes:,} bytes a settings file may have; check the path")
        text = data.decode("utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        reason = "not UTF-8 text" if isinstance(exc, UnicodeDecodeError) else (exc.strerror or type(exc).__name__)
        raise error(f"{path}: cannot be read ({reason}); save it as UTF-8 TOML") from None
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        where = _where(str(exc), text) if quote else _where(str(exc), "")
        raise error(f"{path}: malformed TOML {where}; fix the syntax there") from None
    except RecursionError:
        data = None
    # Dotted headers ([a.a.a...]) parse to any depth without recursion, but copying or
    # walking the result recurses: refuse it here, once, for everything downstream.
    if data is None or _too_deep(data):
        raise error(f"{path}: tables or arrays are nested more than {MAX_TOML_DEPTH} deep; settings files are shallow, check the file")
    return data


MAX_TOML_DEPTH = 32


def _too_deep(data) -> bool:
    """Whether ``data`` nests dicts/lists more than MAX_TOML_DEPTH deep (iterative walk)."""
    stack = [(data, 0)]
    while stack:
        node, depth = stack.pop()
        if depth > MAX_TOML_DEPTH:
            return True
        children = node.values() if isinstance(node, dict) else node if isinstance(node, list) else ()
        stack.extend((child, depth + 1) for child in children if isinstance(child, (dict, list)))
    return False


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
    if not 0 < number <= len(lines):  # no text to quote (or not to be quoted)
        return f"at line {number}: {reason}"
    return f"at line {number}: {reason} in '{lines[number - 1].strip()}'"


def load_preset(kind: str, name: str) -> tuple[dict[str, Any], str]:
    """The mapping of preset ``name`` (bundled name or TOML path) and a label for messages."""
    if not isinstance(name, str) or not name:
        names = ", ".join(available(kind)) or "none"
        raise PresetError(f"{kind} preset {name!r} is not a name; give a string: one of {names} or a .toml path")
    looks_like_path = name.endswith(".toml") or "/" in name or "\\" in name
    if looks_like_path:
        # Someone else's file: small and regular, checked before reading; never quoted.
        path = Path(name)
        return read_toml(path, max_bytes=MAX_PRESET_BYTES, quote=False), str(path)
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
        if not math.isfinite(value):
            raise PresetError(f"{where}: {value} is not a valid value; give a finite number")
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
            raise PresetError(f"{where}: unknown key '{key}'; {did_you_mean(key, allowed)}")
        annotation = types_[key]
        current = getattr(instance, key)
        if dataclasses.is_dataclass(current) and isinstance(value, dict):
            changes[key] = apply_mapping(current, value, f"{where}.{key}")
        else:
            changes[key] = _convert(value, annotation, f"{where}: key '{key}'")
    return dataclasses.replace(instance, **changes)


def did_you_mean(key: str, allowed) -> str:
    """'did you mean ...?' when a close match exists, else the list of allowed keys."""
    import difflib

    close = difflib.get_close_matches(str(key), list(allowed), n=1, cutoff=0.6)
    if close:
        return f"did you mean '{close[0]}'?"
    return f"allowed keys: {', '.join(allowed) or 'none'}"


def parse_override_value(text: str) -> Any:
    """A ``--set KEY=VALUE`` value: TOML syntax (numbers, true/false, [lists], "strings"),
    falling back to a bare string."""
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        return text
