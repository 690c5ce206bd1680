"""Tiny scenes for batch tests: a pinned 8x8 sheet baked for a few frames."""

from __future__ import annotations

from pathlib import Path

import pytest

from clothtool.cook.cooker import CookOptions, cook_fabric
from clothtool.io.fabric_file import write_fabric
from clothtool.mesh.shapes import grid

SCENE = """
version = 1
[scene]
name = "{name}"
fps = 30.0
frames = [1, {end}]
[solver]
preset = "preview"
[output]
attributes = ["velocities", "stats"]
[cloth.sheet]
fabric = "sheet.fabric.h5"
material = "cotton"
"""


def write_shots(folder: Path, ends=(4, 5)) -> Path:
    """folder/sheet.fabric.h5, good scenes a.toml, b.toml (ending at ``ends``) and
    broken.toml (an unknown key)."""
    folder.mkdir(parents=True, exist_ok=True)
    fabric = cook_fabric(grid(8, 8, 0.05, plane="XZ"), CookOptions(pin_box=(-1, -1, -1, 0.01, 1, 1))).fabric
    write_fabric(fabric, folder / "sheet.fabric.h5")
    (folder / "a.toml").write_text(SCENE.format(name="shot_a", end=ends[0]))
    (folder / "b.toml").write_text(SCENE.format(name="shot_b", end=ends[1]))
    (folder / "broken.toml").write_text(SCENE.format(name="shot_broken", end=ends[0]) + "\n[bogus]\nkey = 1\n")
    return folder


@pytest.fixture
def shots(tmp_path: Path) -> Path:
    return write_shots(tmp_path / "shots")


@pytest.fixture
def long_shots(tmp_path: Path) -> Path:
    """The same scenes baked for 40 frames: long enough to kill a batch mid-job."""
    return write_shots(tmp_path / "shots", ends=(40, 40))
