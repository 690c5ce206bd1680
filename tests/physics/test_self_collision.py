"""Self-collision and cloth-cloth collision: folded and stacked cloths keep their distance.

Each scenario is run with and without the collision, so that the test fails when the stage
does nothing: without it the particles come (much) closer than half the distance.
"""

from __future__ import annotations

import numba
import numpy as np
import pytest

from clothtool.bake import bake
from clothtool.cook.cooker import CookOptions, cook_fabric
from clothtool.io.fabric_file import write_fabric
from clothtool.io.memory import MemoryCacheWriter
from clothtool.loading import load_scene
from clothtool.mesh.shapes import grid
from clothtool.profile import StageProfiler
from clothtool.settings import Material, Placement, SolverConfig
from clothtool.solver.cloth import ClothSolver
from clothtool.solver.environment import Environment
from clothtool.solver.frame import Pose
from clothtool.solver.model import build_model
from clothtool.solver.selfcollide import SelfCollideStage

DISTANCE = 0.012  # m: between the grids' edge (0.01) and diagonal (0.014) spacing
SPACING = 0.01
FPS = 60.0
GRAVITY = np.array([0.0, -9.81, 0.0])


def pairwise_min(a: np.ndarray, b: np.ndarray, mask: np.ndarray | None = None) -> float:
    d = np.linalg.norm(a[:, None, :].astype(np.float64) - b[None, :, :].astype(np.float64), axis=2)
    return float(d[mask].min() if mask is not None else d.min())


@pytest.fixture(scope="module")
def towel():
    """A 32 x 16 sheet lying flat (XZ), pinned along column 15 (a rod under it, off-centre so
    the halves are not mirror images): its halves fall and hang down on either side of the
    rod, folded onto each other."""
    mesh = grid(32, 16, SPACING, plane="XZ")
    x = 15 * SPACING
    return cook_fabric(mesh, CookOptions(pin_box=(x - 1e-4, -1.0, -1.0, x + 1e-4, 1.0, 1.0))).fabric


def towel_solver(fabric, self_collision: bool, **config) -> ClothSolver:
    material = Material(self_collision_distance=DISTANCE, damping=0.1)
    model = build_model("towel", fabric, material, Placement(), 1.0, "Y")
    config = SolverConfig(self_collision=self_collision, **config)
    solver = ClothSolver(model, config, Environment(GRAVITY), StageProfiler())
    solver.warm_up()
    return solver


def hang(solver: ClothSolver, frames: int) -> list[float]:
    """Per frame, the smallest distance between particles that are >= DISTANCE apart at rest."""
    rest = solver.model.rest_pos
    far = np.linalg.norm(rest[:, None] - rest[None], axis=2) >= DISTANCE
    closest = []
    for frame in range(1, frames + 1):
        solver.step(frame, (frame - 1) / FPS, 1.0 / FPS)
        closest.append(pairwise_min(solver.state.cur[:, :3], solver.state.cur[:, :3], far))
    return closest


def test_folded_towel_keeps_its_halves_apart(towel):
    with_collision = towel_solver(towel, True)
    assert "self-collide" in with_collision.stage_names
    closest = hang(with_collision, 60)
    assert min(closest) >= 0.5 * DISTANCE, min(closest)
    assert closest[-1] >= 0.9 * DISTANCE  # settled at the distance, not just above half
    # the halves really are folded onto each other: the towel hangs down on both sides
    points = with_collision.state.cur[:, :3]
    assert points[:, 1].min() < -0.14

    without = towel_solver(towel, False)
    assert "self-collide" not in without.stage_names
    closest = hang(without, 60)
    assert min(closest) < 0.25 * DISTANCE, min(closest)
    assert closest[-1] < 0.5 * DISTANCE


def fold_flat(solver: ClothSolver) -> np.ndarray:
    """Puts the towel folded flat onto itself, 0.4 distance apart with some noise (every
    particle collides); returns the positions (float64)."""
    points = solver.model.rest_pos.astype(np.float64)
    right = points[:, 0] > 0.15
    points[right, 0] = 0.3 - points[right, 0]
    points[right, 1] = 0.4 * DISTANCE
    points += np.random.default_rng(7).normal(0.0, 0.1 * DISTANCE, points.shape)
    solver.state.cur[:, :3] = points
    return points


def test_self_collision_does_not_depend_on_the_thread_count(towel):
    """The stage is Jacobi (each particle sums its own corrections from a snapshot), so the
    parallel kernel on 1 or 2 threads and the serial kernel give the same bits. The towel
    is folded flat onto itself, 0.4 distance apart with some noise: every particle collides."""
    runs = []
    threads = numba.get_num_threads()
    try:
        for threshold, count in ((10**9, threads), (1, 1), (1, threads)):
            numba.set_num_threads(count)
            solver = towel_solver(towel, True, parallel_threshold=threshold)
            stage = next(s for s in solver.stages if isinstance(s, SelfCollideStage))
            plan = solver.plan_frame(1, 0.0, 1.0 / FPS)
            points = fold_flat(solver)
            for index in range(5):
                stage.run(solver.iteration(plan, index))
            runs.append(solver.state.cur.copy())
    finally:
        numba.set_num_threads(threads)
    moved = np.linalg.norm(runs[0][:, :3] - points, axis=1)
    assert (moved > 0.1 * DISTANCE).mean() > 0.5  # most particles were pushed
    np.testing.assert_array_equal(runs[0], runs[1])
    np.testing.assert_array_equal(runs[0], runs[2])


def test_a_pair_buffer_too_small_gives_the_same_bits_and_grows_by_the_next_frame(towel):
    """The folded towel's list needs more entries than one per particle: with a buffer of
    that size the stage works through the list in chunks (the same bits as a buffer that
    fits), and the next frame starts with a buffer that holds the whole list."""
    runs = []
    for shrink in (False, True):
        solver = towel_solver(towel, True)
        stage = next(s for s in solver.stages if isinstance(s, SelfCollideStage))
        if shrink:
            stage.pairs = np.zeros(solver.model.particle_count, np.int32)
        plan = solver.plan_frame(1, 0.0, 1.0 / FPS)
        fold_flat(solver)
        for index in range(3):
            stage.run(solver.iteration(plan, index))
        runs.append(solver.state.cur.copy())
    needed = int(stage.list_state[1])
    assert needed > solver.model.particle_count and stage.list_state[0] == 0
    np.testing.assert_array_equal(runs[0], runs[1])
    plan = solver.plan_frame(2, 1.0 / FPS, 1.0 / FPS)
    assert stage.pairs.shape[0] >= needed
    stage.run(solver.iteration(plan, 0))
    assert stage.list_state[0] == 1


@pytest.mark.parametrize(
    "material, config, expected",
    [
        (Material(self_collision_distance=0.01), SolverConfig(self_collision=True), True),
        (Material(self_collision_distance=0.01), SolverConfig(), False),
        (Material(self_collision_distance=0.0), SolverConfig(self_collision=True), False),
        (Material(self_collision_distance=0.01, self_collision_stiffness=0), SolverConfig(self_collision=True), False),
        (Material(self_collision_distance=0.01), SolverConfig(cloth_collision=True), False),  # no neighbours
    ],
)
def test_stage_is_created_only_when_needed(towel, material, config, expected):
    model = build_model("towel", towel, material, Placement(), 1.0, "Y")
    solver = ClothSolver(model, config, Environment(GRAVITY), StageProfiler())
    assert ("self-collide" in solver.stage_names) is expected


# ---------------------------------------------------------------------- cloth-cloth
def trampoline_and_sheet(tmp_path):
    """A 24 x 24 sheet pinned at its corners and a free 12 x 12 sheet 4 cm above its middle."""
    pins = tmp_path / "corners.txt"
    pins.write_text("0 23 552 575\n")
    lower = cook_fabric(grid(24, 24, SPACING, plane="XZ"), CookOptions(pin_file=str(pins))).fabric
    upper = cook_fabric(grid(12, 12, SPACING, plane="XZ", origin=(0.065, 0.04, 0.065)), CookOptions()).fabric
    return lower, upper


def drop(lower, upper, cloth_collision: bool, frames: int = 45):
    """Bake-style interleaved loop; returns the per-frame smallest distance between the two
    cloths and the final heights."""
    material = Material(self_collision_distance=DISTANCE, damping=0.1)
    config = SolverConfig(cloth_collision=cloth_collision)
    profiler = StageProfiler()
    solvers = [
        ClothSolver(build_model(name, fabric, material, Placement(), 1.0, "Y"), config, Environment(GRAVITY), profiler)
        for name, fabric in (("lower", lower), ("upper", upper))
    ]
    if cloth_collision:
        for solver in solvers:
            solver.set_neighbours(solvers)
    for solver in solvers:
        solver.warm_up()
    closest = []
    for frame in range(1, frames + 1):
        plans = [s.plan_frame(frame, (frame - 1) / FPS, 1.0 / FPS) for s in solvers]
        for index in range(plans[0].iterations):
            for solver, plan in zip(solvers, plans):
                solver.iterate(solver.iteration(plan, index))
        closest.append(pairwise_min(solvers[0].state.cur[:, :3], solvers[1].state.cur[:, :3]))
    return closest, solvers


def test_dropped_sheet_rests_on_the_trampoline(tmp_path):
    lower, upper = trampoline_and_sheet(tmp_path)
    closest, solvers = drop(lower, upper, True)
    assert all("self-collide" in s.stage_names for s in solvers)
    assert min(closest) >= 0.5 * DISTANCE, min(closest)
    low, high = (s.state.cur[:, :3] for s in solvers)
    assert high[:, 1].mean() > low[:, 1].mean()
    assert low[:, 1].min() < -0.02  # the trampoline carries the sheet: it sags under it

    closest, solvers = drop(lower, upper, False)
    assert "self-collide" not in solvers[0].stage_names
    low, high = (s.state.cur[:, :3] for s in solvers)
    # closer than the collision distance at some frame end (how much closer depends on where
    # in its fall a frame ends: 0.0067 once geodesic tethers made the trampoline sag less)
    assert min(closest) < DISTANCE
    assert high[:, 1].max() < low[:, 1].min()  # fell straight through


def test_neighbours_are_seen_in_this_cloths_frame(tmp_path):
    """Cloths simulated in different moving frames see each other's particles where they
    are in the world; a sleeping neighbour's particles count as immovable (w = 0)."""
    lower, upper = trampoline_and_sheet(tmp_path)
    material = Material(self_collision_distance=DISTANCE)
    config = SolverConfig(cloth_collision=True)
    angle = 0.4
    turn = np.array([[np.cos(angle), 0, np.sin(angle)], [0, 1, 0], [-np.sin(angle), 0, np.cos(angle)]])
    tracks = [lambda t: Pose(np.eye(3), np.array([0.1 * t, 0.0, 0.0])), lambda t: Pose(turn, np.array([0.0, 0.2, -0.3]))]
    solvers = []
    for name, fabric, track in (("lower", lower, tracks[0]), ("upper", upper, tracks[1])):
        model = build_model(name, fabric, material, Placement(), 1.0, "Y")
        solvers.append(ClothSolver(model, config, Environment(GRAVITY), StageProfiler(), track=track))
    for solver in solvers:
        solver.set_neighbours(solvers)
    plans = [s.plan_frame(1, 0.0, 1.0 / FPS) for s in solvers]
    for solver, plan in zip(solvers, plans):
        solver.iterate(solver.iteration(plan, 0))
    lower_solver, upper_solver = solvers
    stage = next(s for s in lower_solver.stages if isinstance(s, SelfCollideStage))
    stage.gather()
    own = lower_solver.model.particle_count
    expected = lower_solver.history.now.to_local(upper_solver.world_points().astype(np.float64))
    np.testing.assert_allclose(stage.points[own:, :3], expected, atol=1e-6)
    np.testing.assert_array_equal(stage.points[own:, 3], upper_solver.state.cur[:, 3])
    np.testing.assert_array_equal(stage.points[:own], lower_solver.state.cur)
    upper_solver.sleep.fall_asleep(upper_solver)
    stage.gather()
    assert not stage.points[own:, 3].any()


SCENE = """
[scene]
fps = 60.0
frames = [0, 40]
[solver]
preset = "production"
cloth_collision = true
[output]
attributes = []
[cloth.lower]
fabric = "lower.fabric.h5"
material = {{ preset = "cotton", self_collision_distance = {distance} }}
[cloth.upper]
fabric = "upper.fabric.h5"
material = {{ preset = "cotton", self_collision_distance = {distance} }}
"""


def test_bake_hands_each_cloth_its_neighbours(tmp_path):
    lower, upper = trampoline_and_sheet(tmp_path)
    folder = tmp_path / "sub"
    folder.mkdir()
    write_fabric(lower, folder / "lower.fabric.h5")
    write_fabric(upper, folder / "upper.fabric.h5")
    (folder / "scene.toml").write_text(SCENE.format(distance=DISTANCE))
    cache = MemoryCacheWriter()
    stats = bake(load_scene(folder / "scene.toml"), cache)
    assert stats.status == "ok"
    assert "self-collide" in stats.cloths["lower"]["stages"] and "self-collide" in stats.cloths["upper"]["stages"]
    low, high = cache.frames[40]
    assert pairwise_min(low, high) >= 0.5 * DISTANCE
    assert high[:, 1].mean() > low[:, 1].mean()
    assert all(frame["cloths"]["upper"]["asleep"] is False for frame in stats.per_frame)


def test_cloth_pairs_keep_the_larger_distance(tmp_path):
    lower, upper = trampoline_and_sheet(tmp_path)
    config = SolverConfig(cloth_collision=True)
    solvers = [
        ClothSolver(build_model(n, f, Material(self_collision_distance=d), Placement(), 1.0, "Y"), config,
                    Environment(GRAVITY), StageProfiler())
        for n, f, d in (("lower", lower, 0.0), ("upper", upper, 0.02))
    ]
    for solver in solvers:
        solver.set_neighbours(solvers)
    for solver in solvers:
        stage = next(s for s in solver.stages if isinstance(s, SelfCollideStage))
        # own particles: self-collision is off; the neighbour: max(0, 0.02)
        np.testing.assert_array_equal(stage.segment_distance, np.float32([0.0, 0.02]))
