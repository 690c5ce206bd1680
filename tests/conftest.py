"""Shared fixtures. Meshes come from clothtool.mesh.shapes; files go under tmp_path / "sub"."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parent.parent
EXAMPLES = REPO / "examples"

# Keep hypothesis quick and deterministic in CI.
try:
    from hypothesis import settings

    settings.register_profile("ci", max_examples=40, deadline=None, derandomize=True)
    settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))
except ImportError:  # pragma: no cover - hypothesis is a dev dependency
    pass


@pytest.fixture
def out_dir(tmp_path: Path) -> Path:
    """A fresh output directory one level below tmp_path (catches path bugs)."""
    path = tmp_path / "sub"
    path.mkdir()
    return path
