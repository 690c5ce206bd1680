"""A cloth's per-frame strain stats (clothtool.solver.measure.ClothMeter): the one-call
summary's max and mean per phase type equal those of every strain computed and kept (the
percentile path), for an untiled fabric (one span per phase type) and a tiled one (a phase
type's constraints in several spans, clothtool.cook.tiles)."""

from __future__ import annotations

import numpy as np
import pytest

from clothtool.bake import make_solvers
from clothtool.cook import tiles
from clothtool.cook.cooker import CookOptions, cook_fabric
from clothtool.io.fabric_file import write_fabric
from clothtool.loading import load_scene
from clothtool.mesh.shapes import grid
from clothtool.profile import StageProfiler
from clothtool.solver.measure import ClothMeter

SCENE = """
[scene]
fps = 60.0
frames = [0, 3]
[solver]
frequency = 300.0
[cloth.sheet]
fabric = "sheet.fabric.h5"
material = { preset = "cotton" }
"""


@pytest.mark.parametrize("tile_particles", [None, 128], ids=["untiled", "tiled"])
def test_summary_strain_is_the_kept_strains_max_and_mean(tmp_path, monkeypatch, tile_particles):
    n = 30
    if tile_particles:
        monkeypatch.setattr(tiles, "TILE_PARTICLES", tile_particles)
    pin = np.zeros(n * n, np.float32)
    pin[[0, n - 1]] = 1.0
    mesh = grid(n, n, 1.0 / (n - 1)).replace(vertex_attrs={"pin": pin})
    write_fabric(cook_fabric(mesh, CookOptions(pin_attr="pin", tethers="none")).fabric, tmp_path / "sheet.fabric.h5")
    (tmp_path / "scene.toml").write_text(SCENE)
    solver = make_solvers(load_scene(tmp_path / "scene.toml"), StageProfiler())[0]
    meter = ClothMeter(solver)
    assert (len(set(meter.span_labels)) < len(meter.span_labels)) == bool(tile_particles)
    rng = np.random.default_rng(3)
    state = solver.state
    state.cur[:, :3] += rng.normal(0.0, 0.005, (state.cur.shape[0], 3)).astype(state.cur.dtype)
    summary = meter.measure(1.0 / 300.0, percentiles=False)["strain"]
    kept = meter.measure(1.0 / 300.0, percentiles=True)["strain"]
    assert summary.keys() == kept.keys() == {"vertical", "horizontal", "shearing", "bending"}
    for label, stats in summary.items():
        assert stats["max"] == kept[label]["max"]
        assert stats["mean"] == pytest.approx(kept[label]["mean"], rel=1e-12)
