"""Batch files: a TOML list of job groups, for CI pipelines that cook and bake many assets.

    version = 1
    manifest = "out/manifest.json"          # optional [JOBS.manifest.json beside this file]

    [[cook]]                                 # one job per matching mesh
    inputs = ["garments/*.obj"]
    output = "out/fabrics/{name}.fabric.h5"
    preset = "garment"                       # optional
    options = { weld = 1e-5 }                # optional CookOptions fields
    strict = false                           # optional

    [[bake]]                                 # one job per scene and wedge
    inputs = ["shots/*.toml"]
    output = "out/caches/{scene}/{wedge}.usdc"
    set = ["solver.preset=\"production\""]   # optional --set overrides
    frames = [1, 24]                         # optional
    wedge = ["solver.frequency=300,600"]     # optional, Cartesian product
    wedge_zip = []                           # optional, paired lists
    strict = false

Paths are relative to the batch file's directory. Cooks run before bakes.
"""

from __future__ import annotations

from pathlib import Path

from clothtool.batch.jobs import Job, check_distinct_outputs, expand_inputs, expand_wedges, make_jobs
from clothtool.errors import ClothtoolError

FORMAT_VERSION = 1
TOP_LEVEL_KEYS = ("version", "manifest", "cook", "bake")
COOK_KEYS = ("inputs", "output", "preset", "options", "strict")
BAKE_KEYS = ("inputs", "output", "set", "frames", "wedge", "wedge_zip", "strict")


def _fail(path: Path, where: str, message: str):
    raise ClothtoolError(f"{path}: {where} {message}")


def _strings(path: Path, where: str, value) -> list[str]:
    if isinstance(value, str):
        return [value]
    if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
        _fail(path, where, "must be a string or a list of strings")
    return list(value)


def load_batch_file(path: str | Path) -> tuple[list[Job], Path]:
    """The jobs of a batch file and its manifest path."""
    import tomllib

    path = Path(path)
    if not path.is_file():
        raise ClothtoolError(f"{path}: batch file not found; check the path")
    try:
        tables = tomllib.loads(path.read_text())
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise ClothtoolError(f"{path}: not valid TOML ({exc}); fix the syntax") from None
    unknown = [k for k in tables if k not in TOP_LEVEL_KEYS]
    if unknown:
        _fail(path, f"key '{unknown[0]}'", f"is unknown; allowed: {', '.join(TOP_LEVEL_KEYS)}")
    if tables.get("version", FORMAT_VERSION) != FORMAT_VERSION:
        _fail(path, "version", f"{tables['version']!r} is not supported; this clothtool reads version {FORMAT_VERSION}")
    base = path.parent
    manifest = tables.get("manifest", f"{path.stem}.manifest.json")
    if not isinstance(manifest, str) or not manifest:
        _fail(path, "manifest", "must be a file path string")
    jobs: list[Job] = []
    for kind, allowed in (("cook", COOK_KEYS), ("bake", BAKE_KEYS)):
        groups = tables.get(kind, [])
        if not isinstance(groups, list):
            _fail(path, f"[{kind}]", f"must be written [[{kind}]] (a list of job groups)")
        for number, group in enumerate(groups, start=1):
            where = f"[[{kind}]] #{number}"
            jobs += _group(path, where, kind, group, allowed, base, len(jobs))
    if not jobs:
        _fail(path, "", "lists no jobs; add [[cook]] or [[bake]] tables with inputs and output")
    check_distinct_outputs(jobs, f"the output templates of {path}")
    return jobs, base / manifest


def _group(path: Path, where: str, kind: str, group, allowed, base: Path, first_index: int) -> list[Job]:
    if not isinstance(group, dict):
        _fail(path, where, "must be a table")
    unknown = [k for k in group if k not in allowed]
    if unknown:
        _fail(path, f"{where} key '{unknown[0]}'", f"is unknown; allowed: {', '.join(allowed)}")
    for required in ("inputs", "output"):
        if required not in group:
            _fail(path, where, f"needs '{required}'")
    output = group["output"]
    if not isinstance(output, str) or not output:
        _fail(path, f"{where} output", "must be a path template string such as 'out/{name}.usdc'")
    strict = group.get("strict", False)
    if not isinstance(strict, bool):
        _fail(path, f"{where} strict", "must be true or false")
    try:
        inputs = expand_inputs(_strings(path, f"{where} inputs", group["inputs"]), base)
        if kind == "cook":
            options = group.get("options", {})
            if not isinstance(options, dict):
                _fail(path, f"{where} options", "must be a table of cook options, e.g. { weld = 1e-5 }")
            preset = group.get("preset")
            if preset is not None and (not isinstance(preset, str) or not preset):
                _fail(path, f"{where} preset", "must be a preset name or a .toml path")
            if preset and preset.endswith(".toml"):
                preset = str(base / preset)
            return make_jobs("cook", inputs, output, cook_options=options, preset=preset, strict=strict,
                             base=base, first_index=first_index)
        frames = group.get("frames")
        if frames is not None and not (
            isinstance(frames, list) and len(frames) == 2 and all(isinstance(f, int) for f in frames)
        ):
            _fail(path, f"{where} frames", "must be [START, END], e.g. [1, 24]")
        wedges = expand_wedges(_strings(path, f"{where} wedge", group.get("wedge", [])),
                               _strings(path, f"{where} wedge_zip", group.get("wedge_zip", [])))
        return make_jobs("bake", inputs, output, wedges=wedges,
                         overrides=tuple(_strings(path, f"{where} set", group.get("set", []))),
                         frames=tuple(frames) if frames else None, strict=strict, base=base, first_index=first_index)
    except ClothtoolError as exc:
        if str(exc).startswith(str(path)):
            raise
        raise ClothtoolError(f"{path}: {where}: {exc}") from None
