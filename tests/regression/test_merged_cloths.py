"""Many cloths through one solve (clothtool.solver.merge): a bake with the cloths merged
writes the same cache bytes and reports the same stats as a bake that solves each cloth on
its own, and cloths whose solve cannot be shared are not merged."""

from __future__ import annotations

import numpy as np
import pytest

from clothtool.bake import BakeOptions, bake, make_solvers
from clothtool.cook.cooker import CookOptions, cook_fabric
from clothtool.io.fabric_file import write_fabric
from clothtool.loading import load_scene
from clothtool.mesh.shapes import grid
from clothtool.profile import StageProfiler
from clothtool.solver.cloth import ClothSolver
from clothtool.solver.merge import GroupMember, merged_model

# copies of one sheet at different places, turned and scaled: their particles see different
# numbers, so a mix-up between cloths would show
PLACEMENTS = (
    'translate = [0.0, 0.0, 0.0]',
    'translate = [1.3, 0.2, -0.4]\nrotate_euler = [0.0, 35.0, 0.0]',
    'translate = [-1.1, 0.5, 0.9]\nscale = 0.8',
    'translate = [0.4, -0.3, 2.0]\nrotate_euler = [10.0, -60.0, 5.0]\nscale = 1.25',
)
SCENE = """
[scene]
fps = 60.0
frames = [0, {frames}]
[solver]
preset = "production"
frequency = 300.0
precision = "{precision}"
stiffness_mode = "{mode}"
{solver}
[output]
attributes = ["velocities", "stats"]
"""
CLOTH = """
[cloth.sheet{k}]
fabric = "sheet.fabric.h5"
{placement}
{extra}
material = {{ preset = "cotton", drag_coefficient = {drag}, lift_coefficient = {lift}, damping = 0.1 }}
"""


def write_sheet(folder, n: int = 13, max_distance: bool = False) -> None:
    """An n x n sheet 1 m across pinned at its top corners, with geodesic tethers (and a
    painted max distance growing down the sheet)."""
    mesh = grid(n, n, 1.0 / (n - 1))
    pin = np.zeros(n * n, np.float32)
    pin[[0, n - 1]] = 1.0
    attrs = {"pin": pin}
    options = dict(pin_attr="pin", tethers="geodesic")
    if max_distance:
        attrs["reach"] = np.repeat(np.linspace(0.0, 1.0, n), n).astype(np.float32)
        options.update(max_distance_attr="reach", max_distance_range=(0.0, 0.05))
    fabric = cook_fabric(mesh.replace(vertex_attrs=attrs), CookOptions(**options)).fabric
    write_fabric(fabric, folder / "sheet.fabric.h5")


def scene_file(folder, *, copies=4, frames=24, precision="float64", mode="nvcloth", solver="", drag=0.4, lift=0.2,
               extra="", materials=None, n=13, max_distance=False):
    write_sheet(folder, n, max_distance)
    text = SCENE.format(frames=frames, precision=precision, mode=mode, solver=solver)
    for k in range(copies):
        d = drag if materials is None else materials[k]
        text += CLOTH.format(k=k, placement=PLACEMENTS[k % len(PLACEMENTS)], extra=extra, drag=d, lift=lift)
    path = folder / "scene.toml"
    path.write_text(text)
    return load_scene(path)


def merged_and_apart(scene, tmp_path, **options) -> tuple[bytes, bytes, object, object]:
    outputs, stats = [], []
    for merge in (True, False):
        path = tmp_path / f"out_{merge}.h5"
        stats.append(bake(scene, path, BakeOptions(merge_cloths=merge, **options)))
        outputs.append(path.read_bytes())
    return outputs[0], outputs[1], stats[0], stats[1]


def solver_kinds(scene) -> list[str]:
    return [type(s).__name__ for s in make_solvers(scene, StageProfiler())]


@pytest.mark.parametrize(
    "precision, mode, extra, max_distance",
    [
        ("float64", "nvcloth", "", False),
        ("float32", "nvcloth", "", True),
        ("float64", "xpbd", "backstop = { radius = 0.5, distance = 0.01 }", False),
    ],
)
def test_merged_bake_writes_the_same_bytes(tmp_path, precision, mode, extra, max_distance):
    scene = scene_file(tmp_path, precision=precision, mode=mode, extra=extra, max_distance=max_distance)
    assert solver_kinds(scene) == ["GroupMember"] * 4
    merged, apart, merged_stats, apart_stats = merged_and_apart(scene, tmp_path)
    assert merged == apart
    assert merged_stats.per_frame == apart_stats.per_frame
    assert merged_stats.cloths == apart_stats.cloths
    assert merged_stats.stages == apart_stats.stages
    # the sheets moved, each in its own way (a test of nothing would pass the above too)
    last = merged_stats.per_frame[-1]["cloths"]
    speeds = [last[f"sheet{k}"]["max_speed"] for k in range(4)]
    assert min(speeds) > 0 and len(set(speeds)) > 1


def test_merged_bake_with_percentiles_and_penetration_reports_the_same(tmp_path):
    """Percentiles come from each cloth's own meter, the rest from the group's measure."""
    scene = scene_file(tmp_path, copies=3, frames=8)
    merged, apart, merged_stats, apart_stats = merged_and_apart(scene, tmp_path, percentiles=True, penetration=True)
    assert merged == apart
    assert merged_stats.per_frame == apart_stats.per_frame
    assert "p99" in merged_stats.per_frame[-1]["cloths"]["sheet2"]["strain"]["bending"]


def test_merged_bake_with_stage_profile_is_the_same(tmp_path):
    """--profile runs the merged cloth's stages one by one from Python: the same bits."""
    scene = scene_file(tmp_path, copies=3, frames=10, precision="float32")
    profiled = tmp_path / "profiled.h5"
    bake(scene, profiled, BakeOptions(profile_stages=True))
    plain = tmp_path / "plain.h5"
    bake(scene, plain, BakeOptions(merge_cloths=False))
    assert profiled.read_bytes() == plain.read_bytes()


def test_each_cloth_of_a_merged_bake_is_the_cloth_baked_alone(tmp_path):
    """Against a bake of the one cloth: a sheet's frames do not depend on the others."""
    scene = scene_file(tmp_path, copies=4, frames=12)
    assert solver_kinds(scene) == ["GroupMember"] * 4
    together = bake(scene, "null", BakeOptions(merge_cloths=True))
    (tmp_path / "alone").mkdir()
    alone_scene = scene_file(tmp_path / "alone", copies=1, frames=12)
    alone = bake(alone_scene, "null")
    for frame_together, frame_alone in zip(together.per_frame, alone.per_frame):
        assert frame_together["cloths"]["sheet0"] == frame_alone["cloths"]["sheet0"]


def test_cloths_of_different_materials_form_separate_groups(tmp_path):
    scene = scene_file(tmp_path, copies=4, materials=[0.4, 0.3, 0.4, 0.3], frames=8)
    solvers = make_solvers(scene, StageProfiler())
    groups = [s.group for s in solvers]
    assert groups[0] is groups[2] and groups[1] is groups[3] and groups[0] is not groups[1]
    assert [s.leader for s in solvers] == [True, True, False, False]
    merged, apart, _, _ = merged_and_apart(scene, tmp_path)
    assert merged == apart


@pytest.mark.parametrize(
    "solver, extra",
    [
        ("self_collision = true", ""),
        ("cloth_collision = true", ""),
        ("sleep_threshold = 0.05", ""),
        ("", 'track = "spin"'),
        ("", "initial_velocity = [0.0, 1.0, 0.0]"),  # (only in the first cloth: see below)
    ],
)
def test_cloths_that_cannot_share_a_solve_are_solved_apart(tmp_path, solver, extra):
    scene = scene_file(tmp_path, copies=2, solver=solver, frames=4)
    if extra:
        text = (tmp_path / "scene.toml").read_text().replace("[cloth.sheet1]", f"{extra}\n[cloth.sheet1]", 1)
        if "track" in extra:
            text += '[track.spin]\nkeys = [{ time = 0, rotate_euler = [0, 0, 0] }, { time = 4, rotate_euler = [0, 20, 0] }]\n'
        (tmp_path / "scene.toml").write_text(text)
        scene = load_scene(tmp_path / "scene.toml")
    assert solver_kinds(scene) == ["ClothSolver", "ClothSolver"]


def test_free_cloths_and_scenes_with_colliders_are_solved_apart(tmp_path):
    """A free cloth is damped relative to its own mean motion; colliders add per-cloth
    collision points: neither is merged."""
    mesh = grid(5, 5, 0.25)
    write_fabric(cook_fabric(mesh, CookOptions()).fabric, tmp_path / "sheet.fabric.h5")
    text = SCENE.format(frames=4, precision="float64", mode="nvcloth", solver="")
    for k in range(2):
        text += CLOTH.format(k=k, placement=PLACEMENTS[k], extra="", drag=0.0, lift=0.0)
    (tmp_path / "scene.toml").write_text(text)
    assert solver_kinds(load_scene(tmp_path / "scene.toml")) == ["ClothSolver", "ClothSolver"]
    (tmp_path / "pinned").mkdir()
    scene_file(tmp_path / "pinned", copies=2, frames=4)
    text = (tmp_path / "pinned" / "scene.toml").read_text()
    text += '[collider.ball]\nkind = "sphere"\ncenter = [0.5, -1.5, 0.0]\nradius = 0.3\n'
    (tmp_path / "pinned" / "scene.toml").write_text(text)
    assert solver_kinds(load_scene(tmp_path / "pinned" / "scene.toml")) == ["ClothSolver", "ClothSolver"]


def test_merged_model_is_the_disjoint_union(tmp_path):
    """Particles concatenated; every member's constraints, sets and tethers present once,
    offset by its first particle, in its own order; no set moves a particle twice."""
    scene = scene_file(tmp_path, copies=3, frames=2, n=7)
    models = [s.model for s in make_solvers(scene, StageProfiler(), merge=False)]
    union = merged_model(models)
    offsets = np.cumsum([0] + [m.particle_count for m in models])
    assert union.particle_count == offsets[-1]
    np.testing.assert_array_equal(union.rest_pos, np.concatenate([m.rest_pos for m in models]))
    for s in range(union.set_offsets.shape[0] - 1):
        pairs = union.constraint_indices[union.set_offsets[s]:union.set_offsets[s + 1]]
        movable = pairs[union.inv_mass[pairs] > 0]
        assert np.unique(movable).size == movable.size
    for k, m in enumerate(models):
        mine = (union.constraint_indices[:, 0] >= offsets[k]) & (union.constraint_indices[:, 0] < offsets[k + 1])
        np.testing.assert_array_equal(union.constraint_indices[mine] - offsets[k], m.constraint_indices)
        np.testing.assert_array_equal(union.constraint_rest_length[mine], m.constraint_rest_length)
        n, total = m.particle_count, union.particle_count
        for slot in range(m.tether_anchor.shape[0] // n):
            rows = slice(slot * total + offsets[k], slot * total + offsets[k + 1])
            np.testing.assert_array_equal(union.tether_anchor[rows], m.tether_anchor[slot * n:(slot + 1) * n] + offsets[k])
            np.testing.assert_array_equal(union.tether_rest_length[rows], m.tether_rest_length[slot * n:(slot + 1) * n])
    assert isinstance(make_solvers(scene, StageProfiler())[0], GroupMember)
    assert all(type(s) is ClothSolver for s in make_solvers(scene, StageProfiler(), merge=False))
