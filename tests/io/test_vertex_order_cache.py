"""Caches present a cloth's points in its mesh's vertex order, whatever order the cook chose
for the particles (``Fabric.particle_vertex``): DCCs match points to vertices by index."""

from __future__ import annotations

import numpy as np
import pytest

from clothtool.bake import bake
from clothtool.cook import locality
from clothtool.cook.cooker import CookOptions, cook_fabric
from clothtool.io.cache import read_cache
from clothtool.io.fabric_file import write_fabric
from clothtool.loading import load_scene
from clothtool.mesh.shapes import grid

SCENE = """
version = 1
[scene]
fps = 30.0
frames = [1, 6]
[solver]
preset = "preview"
[output]
attributes = ["velocities"]
[cloth.sheet]
fabric = "{fabric}"
material = "cotton"
"""


@pytest.fixture(scope="module")
def mesh():
    """A 12x12 sheet lying flat with its vertices in random order, pinned along one edge
    (painted), so that it swings down."""
    sheet = grid(12, 12, 0.05, plane="XZ", quads=True)
    sheet = locality.reorder_mesh(sheet, np.random.default_rng(7).permutation(sheet.vertex_count))
    pin = (sheet.vertex_pos[:, 0] < 0.01).astype(np.float32)
    return sheet.replace(vertex_attrs={"pin": pin})


def baked(folder, fabric, suffix=".h5"):
    folder.mkdir(parents=True, exist_ok=True)
    write_fabric(fabric, folder / "sheet.fabric.h5")
    (folder / "scene.toml").write_text(SCENE.format(fabric="sheet.fabric.h5"))
    output = folder / f"out{suffix}"
    bake(load_scene(folder / "scene.toml"), output)
    return output


def cache_arrays(path):
    with read_cache(path) as cache:
        cloth = cache.header.cloths[0]
        frames = np.stack([cache.points("sheet", f) for f in cache.frames])
        velocities = np.stack([cache.velocities("sheet", f) for f in cache.frames])
        return cloth, frames, velocities


def test_reordered_bake_writes_exactly_the_solver_state_in_vertex_order(tmp_path, mesh):
    """The same fabric baked twice, once with its particle order dropped (so the cache holds
    particles as the solver numbers them): the reordered cache is that one, un-permuted."""
    fabric = cook_fabric(mesh, CookOptions(pin_attr="pin")).fabric
    assert fabric.reordered
    in_vertex_order, frames, velocities = cache_arrays(baked(tmp_path / "a", fabric))
    as_particles, raw_frames, raw_velocities = cache_arrays(baked(tmp_path / "b", fabric.replace(particle_vertex=np.zeros(0, np.int32))))
    gather = fabric.vertex_particle
    np.testing.assert_array_equal(frames, raw_frames[:, gather])
    np.testing.assert_array_equal(velocities, raw_velocities[:, gather])
    np.testing.assert_array_equal(in_vertex_order.rest_pos, as_particles.rest_pos[gather])
    np.testing.assert_array_equal(in_vertex_order.vertex_primvars["pin"], as_particles.vertex_primvars["pin"][gather])
    np.testing.assert_array_equal(in_vertex_order.face_vertex_indices, mesh.face_vertex_indices)
    np.testing.assert_array_equal(frames[0], mesh.vertex_pos)  # the first frame is the rest pose


@pytest.mark.parametrize("suffix", [".h5", ".usdc"])
def test_reordered_and_plain_cooks_bake_the_same_cloth_in_the_same_order(tmp_path, mesh, suffix):
    """A bake of the renumbered fabric matches one of the fabric cooked in vertex order:
    same topology and pin map exactly, points close (the constraints are solved in another
    order, so the Gauss-Seidel iterates differ slightly)."""
    local = cook_fabric(mesh, CookOptions(pin_attr="pin")).fabric
    plain = cook_fabric(mesh, CookOptions(pin_attr="pin", reorder=False)).fabric
    a, b = baked(tmp_path / "local", local, suffix), baked(tmp_path / "plain", plain, suffix)
    with read_cache(a) as first, read_cache(b) as second:
        x, y = first.header.cloths[0], second.header.cloths[0]
        np.testing.assert_array_equal(x.face_vertex_counts, y.face_vertex_counts)
        np.testing.assert_array_equal(x.face_vertex_indices, y.face_vertex_indices)
        np.testing.assert_array_equal(x.rest_pos, y.rest_pos)
        np.testing.assert_array_equal(x.vertex_primvars["pin"], y.vertex_primvars["pin"])
        assert first.frames == second.frames
        last = first.frames[-1]
        moved = np.abs(second.points("sheet", last) - second.points("sheet", first.frames[0])).max()
        assert moved > 0.05  # the sheet swung down: the comparison below means something
        np.testing.assert_allclose(first.points("sheet", last), second.points("sheet", last), atol=0.02 * moved)
