"""clothtool warmup's variants: each bakes a scene its integrator accepts (a scene asking for
a capability the integrator lacks is refused, which would stop the warm-up)."""

from __future__ import annotations

import pytest

from clothtool import warmup
from clothtool.loading import load_scene
from clothtool.sim.integrators import check_capabilities, requested_capabilities


@pytest.mark.parametrize("variant", warmup.variants(), ids=lambda v: v.label)
def test_every_variant_asks_only_for_what_its_integrator_does(tmp_path, variant):
    (tmp_path / "grid.obj").write_text(warmup._grid_obj(warmup.GRID))
    (tmp_path / "warmup.toml").write_text(variant.scene_text())
    scene = load_scene(tmp_path / "warmup.toml", list(variant.overrides))
    spec = check_capabilities(scene)
    assert set(requested_capabilities(scene)) <= spec.capabilities
    assert "collision" in requested_capabilities(scene)


def test_the_position_based_variants_ask_for_everything():
    pbd = next(v for v in warmup.variants() if v.label.startswith("pbd"))
    text = pbd.scene_text()
    assert all(start in text for start in warmup.CAPABILITY_LINES)
