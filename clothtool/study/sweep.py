"""Sweeps: ``KEY=V1,V2,...`` over scene or preset keys, combined as a Cartesian product."""

from __future__ import annotations

import dataclasses
import itertools

from clothtool.errors import ClothtoolError
from clothtool.presets import parse_override_value


@dataclasses.dataclass(frozen=True)
class Sweep:
    key: str
    values: tuple

    @classmethod
    def parse(cls, text: str) -> "Sweep":
        if "=" not in text:
            raise ClothtoolError(f"--sweep {text}: expected KEY=V1,V2,..., e.g. solver.frequency=60,120,240")
        key, values = text.split("=", 1)
        items = [parse_override_value(v.strip()) for v in values.split(",") if v.strip()]
        if not key.strip() or not items:
            raise ClothtoolError(f"--sweep {text}: give a key and at least one value")
        return cls(key.strip(), tuple(items))


def format_value(value) -> str:
    return f"{value:g}" if isinstance(value, float) else str(value)


@dataclasses.dataclass(frozen=True)
class Setting:
    """One point of a study: a value per swept key. The first sweep is the curve's x variable;
    the others name the family (one curve per family)."""

    values: tuple[tuple[str, object], ...]

    @property
    def overrides(self) -> list[str]:
        return [f"{key}={_toml(value)}" for key, value in self.values]

    @property
    def label(self) -> str:
        return format_value(self.values[0][1]) if self.values else "scene"

    @property
    def family(self) -> str:
        rest = self.values[1:]
        return ", ".join(f"{k.split('.')[-1]}={format_value(v)}" for k, v in rest) or "all"

    def as_dict(self) -> dict:
        return {key: value for key, value in self.values}


def _toml(value) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return f'"{value}"'
    return repr(value)


def settings(sweeps: list[Sweep]) -> list[Setting]:
    """Every combination; families vary slowest so each curve's points are consecutive."""
    if not sweeps:
        return [Setting(())]
    x, rest = sweeps[0], sweeps[1:]
    combos = []
    for family in itertools.product(*[[(s.key, v) for v in s.values] for s in rest]):
        for value in x.values:
            combos.append(Setting(((x.key, value), *family)))
    return combos
