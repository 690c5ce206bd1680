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


@pytest.fixture
def shots(tmp_path: Path) -> Path:
    """tmp/shots: sheet.fabric.h5, good scenes a.toml, b.toml, and broken.toml (an unknown key)."""
    folder = tmp_path / "shots"
    folder.mkdir()
    fabric = cook_fabric(grid(8, 8, 0.05, plane="XZ"), CookOptions(pin_box=(-1, -1, -1, 0.01, 1, 1))).fabric
    write_fabric(fabric, folder / "sheet.fabric.h5")
    (folder / "a.toml").write_text(SCENE.format(name="shot_a", end=4))
    (folder / "b.toml").write_text(SCENE.format(name="shot_b", end=5))
    (folder / "broken.toml").write_text(SCENE.format(name="shot_broken", end=4) + "\n[bogus]\nkey = 1\n")
    return folder
