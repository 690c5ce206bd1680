"""A job's input files and their content hashes (what resume compares).

A cook reads its mesh (and a preset or pin file given as a path). A bake reads its scene
file and every file the scene names (fabrics, meshes cooked on the fly, tracks, collider
meshes, presets given as paths): any string in the scene's TOML that names an existing
file next to the scene counts, so a changed fabric re-bakes every scene that uses it.
"""

from __future__ import annotations

import hashlib
import tomllib
from pathlib import Path

from clothtool.batch.jobs import Job

CHUNK = 1 << 20


def file_sha256(path: str | Path) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        for block in iter(lambda: handle.read(CHUNK), b""):
            digest.update(block)
    return digest.hexdigest()


def _strings(value):
    if isinstance(value, str):
        yield value
    elif isinstance(value, dict):
        for item in value.values():
            yield from _strings(item)
    elif isinstance(value, list):
        for item in value:
            yield from _strings(item)


def referenced_files(scene: Path) -> list[Path]:
    """Files named by strings in the scene TOML, relative to the scene's directory."""
    try:
        with open(scene, "rb") as handle:
            tables = tomllib.load(handle)
    except (OSError, tomllib.TOMLDecodeError):
        return []  # the bake itself reports the unreadable scene
    found = []
    for text in _strings(tables):
        if not text or "\n" in text or len(text) > 4096:
            continue
        candidate = scene.parent / text
        try:
            if candidate.is_file() and candidate not in found:
                found.append(candidate)
        except OSError:
            continue
    return found


def job_inputs(job: Job) -> list[Path]:
    """Every existing file the job reads, the main input first."""
    main = Path(job.input)
    if not main.is_file():
        return []
    files = [main]
    if job.kind == "bake":
        files += referenced_files(main)
    else:
        options = dict(job.cook_options)
        for extra in (job.preset, options.get("pin_file")):  # a bundled preset name is no file
            if isinstance(extra, str) and extra and Path(extra).is_file():
                files.append(Path(extra))
    unique = []
    for path in files:
        if path not in unique:
            unique.append(path)
    return unique


def hash_inputs(job: Job) -> dict[Path, str]:
    return {path: file_sha256(path) for path in job_inputs(job)}
