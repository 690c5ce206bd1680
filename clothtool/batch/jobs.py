"""Jobs: pure descriptions of one cook or one bake, and how many of them are made.

A job names its kind, its input, its output and the settings that differ from the input's
own; running it (``clothtool.batch.execute.run_job``) is a separate, picklable step, so a
job can travel to a worker process or a Dask worker unchanged.

Many jobs come from input patterns (globs) and an output template such as
``caches/{scene}/{wedge}.usdc``; wedges (``KEY=V1,V2,...``) multiply every bake into one
job per combination of values.
"""

from __future__ import annotations

import dataclasses
import glob
import itertools
import re
import string
import tomllib
from pathlib import Path

from clothtool.errors import ClothtoolError
from clothtool.presets import parse_override_value

KINDS = ("cook", "bake")
TEMPLATE_FIELDS = ("name", "scene", "wedge", "index", "kind")
NO_WEDGE_LABEL = "base"
_UNSAFE = re.compile(r"[^A-Za-z0-9.+-]+")


@dataclasses.dataclass(frozen=True)
class Job:
    """One cook or bake.

    Attributes:
        kind: "cook" (a mesh into a fabric file) or "bake" (a scene into a cache).
        input: the mesh or scene file.
        output: the fabric or cache file to write.
        overrides: bake: ``--set``-style KEY=VALUE strings applied to the scene.
        cook_options: cook: CookOptions field -> value (sorted pairs), over the preset.
        preset: cook: preset name or .toml path.
        frames: bake: (start, end) to bake instead of the scene's range.
        wedge: bake: (key, value) pairs of this wedge, applied after ``overrides`` and
            recorded in the cache metadata.
        strict: treat mesh repairs and warnings as errors.
    """

    kind: str
    input: str
    output: str
    overrides: tuple[str, ...] = ()
    cook_options: tuple[tuple[str, object], ...] = ()
    preset: str | None = None
    frames: tuple[int, int] | None = None
    wedge: tuple[tuple[str, object], ...] = ()
    strict: bool = False

    @property
    def wedge_overrides(self) -> list[str]:
        return [f"{key}={toml_value(value)}" for key, value in self.wedge]

    @property
    def wedge_label(self) -> str:
        return wedge_label(self.wedge)

    def settings(self) -> dict:
        """What this job asks for beyond its input file, as JSON: compared on resume."""
        if self.kind == "cook":
            return {"preset": self.preset, "options": {k: _jsonable(v) for k, v in self.cook_options}, "strict": self.strict}
        return {
            "set": list(self.overrides),
            "frames": list(self.frames) if self.frames else None,
            "wedge": {k: _jsonable(v) for k, v in self.wedge},
            "strict": self.strict,
        }


@dataclasses.dataclass(frozen=True)
class Sweep:
    """``KEY=V1,V2,...``: values to wedge a scene or preset key over (TOML-typed values).
    (The study's sweeps read the same syntax; this copy keeps ``clothtool.batch`` from
    importing the study, and with it numba, in processes that only describe jobs.)"""

    key: str
    values: tuple

    @classmethod
    def parse(cls, text: str) -> "Sweep":
        key, _, values = text.partition("=")
        items = [parse_override_value(v.strip()) for v in values.split(",") if v.strip()]
        if not key.strip() or not items:
            raise ClothtoolError(f"--wedge {text}: expected KEY=V1,V2,..., e.g. solver.frequency=300,600")
        return cls(key.strip(), tuple(items))


def format_value(value) -> str:
    return f"{value:g}" if isinstance(value, float) else str(value)


def toml_value(value) -> str:
    """``value`` written back as TOML for a ``--set`` override."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return '"' + value.replace("\\", "\\\\").replace('"', '\\"') + '"'
    return repr(value)


def _jsonable(value):
    return list(value) if isinstance(value, tuple) else value


def wedge_label(wedge: tuple[tuple[str, object], ...]) -> str:
    """A file-name-safe label: ``frequency-300_stiffness_mode-xpbd`` (last key component,
    the full key when two wedged keys share their last component)."""
    if not wedge:
        return NO_WEDGE_LABEL
    lasts = [key.split(".")[-1] for key, _ in wedge]
    parts = []
    for (key, value), last in zip(wedge, lasts):
        name = last if lasts.count(last) == 1 else key.replace(".", "-")
        parts.append(f"{name}-{_UNSAFE.sub('-', format_value(value)).strip('-')}")
    return "_".join(parts)


def expand_wedges(product: list[str] = (), zipped: list[str] = ()) -> list[tuple[tuple[str, object], ...]]:
    """Every wedge: the Cartesian product of the ``product`` sweeps (first varies slowest),
    times the ``zipped`` sweeps taken in step (they must have equal lengths)."""
    sweeps = [Sweep.parse(text) for text in product]
    zips = [Sweep.parse(text) for text in zipped]
    keys = [s.key for s in sweeps + zips]
    repeated = sorted({k for k in keys if keys.count(k) > 1})
    if repeated:
        raise ClothtoolError(f"--wedge {repeated[0]}: the key is wedged twice; give it once with all its values")
    if zips and len({len(s.values) for s in zips}) > 1:
        lengths = ", ".join(f"{s.key} has {len(s.values)}" for s in zips)
        raise ClothtoolError(f"--wedge-zip: paired lists must have equal lengths ({lengths})")
    zip_rows = [tuple((s.key, s.values[i]) for s in zips) for i in range(len(zips[0].values))] if zips else [()]
    product_rows = itertools.product(*[[(s.key, v) for v in s.values] for s in sweeps])
    return [tuple(row) + zipped_row for row in product_rows for zipped_row in zip_rows]


def expand_inputs(patterns: list[str], base: Path | None = None) -> list[Path]:
    """Input files from paths and glob patterns (``dir/*.obj``, ``**``), in order, each once.

    A plain path is kept even when missing (its job then fails alone with a clear line);
    a pattern that matches nothing is an error.
    """
    found: list[Path] = []
    for pattern in patterns:
        full = str(base / pattern) if base is not None and not Path(pattern).is_absolute() else str(pattern)
        if glob.has_magic(pattern):
            matches = sorted(glob.glob(full, recursive=True))
            matches = [m for m in matches if Path(m).is_file()]
            if not matches:
                raise ClothtoolError(f"{pattern}: the pattern matches no file; check the directory and the quoting")
            found += [Path(m) for m in matches]
        else:
            found.append(Path(full))
    unique: list[Path] = []
    for path in found:
        if path not in unique:
            unique.append(path)
    return unique


def check_template(template: str) -> None:
    try:
        fields = [name for _, name, _, _ in string.Formatter().parse(template) if name is not None]
    except ValueError as exc:
        raise ClothtoolError(f"-o {template}: not a valid output template ({exc}); write fields as {{name}}") from None
    for name in fields:
        if name not in TEMPLATE_FIELDS:
            allowed = ", ".join("{" + f + "}" for f in TEMPLATE_FIELDS)
            raise ClothtoolError(f"-o {template}: unknown template field '{{{name}}}'; use {allowed}")


def scene_name(path: Path) -> str:
    """The scene's [scene] name (its file stem when unset), read without loading the scene."""
    try:
        with open(path, "rb") as handle:
            name = tomllib.load(handle).get("scene", {}).get("name")
    except (OSError, tomllib.TOMLDecodeError, AttributeError):
        name = None
    return name if isinstance(name, str) and name else path.stem


def input_name(path: Path) -> str:
    """The input's name for templates: its file name without suffixes (skirt.fabric.h5 -> skirt)."""
    return path.name.split(".")[0] or path.stem


def render_output(template: str, kind: str, path: Path, wedge, index: int) -> str:
    fields = {
        "name": input_name(path),
        "scene": scene_name(path) if kind == "bake" else input_name(path),
        "wedge": wedge_label(wedge),
        "index": index,
        "kind": kind,
    }
    return template.format_map(fields)


def make_jobs(
    kind: str,
    inputs: list[Path],
    template: str,
    *,
    wedges: list[tuple[tuple[str, object], ...]] = ((),),
    overrides: tuple[str, ...] = (),
    cook_options: dict | None = None,
    preset: str | None = None,
    frames: tuple[int, int] | None = None,
    strict: bool = False,
    base: Path | None = None,
    first_index: int = 0,
) -> list[Job]:
    """One job per input and wedge, outputs named by ``template`` (relative to ``base``)."""
    if kind not in KINDS:
        raise ClothtoolError(f"job kind '{kind}' is not one of {', '.join(KINDS)}")
    if kind == "cook" and any(wedges):
        raise ClothtoolError("--wedge applies to bakes only; cook each variant with its own options")
    check_template(template)
    options = tuple(sorted((cook_options or {}).items()))
    jobs = []
    for path in inputs:
        for wedge in wedges:
            output = render_output(template, kind, path, wedge, first_index + len(jobs))
            if base is not None and not Path(output).is_absolute():
                output = str(base / output)
            jobs.append(Job(kind, str(path), output, tuple(overrides), options, preset, frames, tuple(wedge), strict))
    return jobs


def check_distinct_outputs(jobs: list[Job], template_hint: str = "the output template") -> None:
    """Refuse two jobs writing one file (a template without {name} or {wedge})."""
    seen: dict[str, Job] = {}
    for job in jobs:
        key = str(Path(job.output).resolve())
        if key in seen:
            other = seen[key]
            raise ClothtoolError(
                f"{job.output}: jobs for {Path(other.input).name} ({other.wedge_label}) and {Path(job.input).name} "
                f"({job.wedge_label}) would both write it; add {{name}}, {{scene}} or {{wedge}} to {template_hint}"
            )
        seen[key] = job
