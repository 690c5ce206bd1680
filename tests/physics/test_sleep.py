"""Sleeping (NvCloth's updateSleepState): still cloths stop running stages until woken.

Costs are checked by counting stage calls (the profiler counts every stage run), so the
tests do not depend on timings: an asleep cloth runs no stage at all.
"""

from __future__ import annotations

import types

import numpy as np
import pytest

from clothtool.bake import bake
from clothtool.collision.colliders import ColliderArrays
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
from clothtool.solver.iteration import FramePlan
from clothtool.solver.model import build_model
from clothtool.solver.sleep import driven_by

FPS = 60.0
GRAVITY = np.array([0.0, -9.81, 0.0])
SLEEPY = SolverConfig(sleep_threshold=0.02, sleep_test_interval=0.05, sleep_after_count=4)


@pytest.fixture(scope="module")
def curtain():
    """16 x 16 particles 2 cm apart hanging from their pinned top row."""
    return cook_fabric(grid(16, 16, 0.02), CookOptions(pin_box=(-1.0, -1e-4, -1.0, 1.0, 1.0, 1.0))).fabric


def make(fabric, config=SLEEPY, **kwargs) -> ClothSolver:
    model = build_model("curtain", fabric, Material(damping=0.2), Placement(), 1.0, "Y")
    solver = ClothSolver(model, config, Environment(GRAVITY), StageProfiler(), **kwargs)
    solver.warm_up()
    return solver


def run(solver: ClothSolver, frames: int, first: int = 1) -> list[dict]:
    """Per frame: asleep at its end, stage calls and stage seconds during it."""
    profiler = solver.profiler
    log = []
    for frame in range(first, first + frames):
        calls, seconds = sum(profiler.calls.values()), sum(profiler.seconds.values())
        plan = solver.step(frame, (frame - 1) / FPS, 1.0 / FPS)
        log.append(
            {
                "asleep": solver.asleep,
                "calls": sum(profiler.calls.values()) - calls,
                "seconds": sum(profiler.seconds.values()) - seconds,
                "iterations": plan.iterations,
            }
        )
    return log


def test_swinging_curtain_falls_asleep_and_stops_running_stages(curtain):
    solver = make(curtain, initial_velocity=(0.0, 0.0, 0.5))
    assert solver.stage_names[-1] == "sleep"
    log = run(solver, 120)
    asleep = [f["asleep"] for f in log]
    assert asleep[0] is False and asleep[-1] is True
    first = asleep.index(True)
    assert first >= 8  # the swing takes a while to die down: 4 still tests of 0.05 s at least
    assert all(asleep[first:]), "nothing wakes it, so it stays asleep"
    stages = len(solver.stages)
    for f in log[: first + 1]:  # awake (it falls asleep during frame `first`)
        assert f["calls"] > 0
    for f in log[:first]:
        assert f["calls"] == f["iterations"] * stages
    for f in log[first + 1 :]:
        assert f["calls"] == 0 and f["seconds"] == 0.0
    awake_s = sum(f["seconds"] for f in log[:first])
    asleep_s = sum(f["seconds"] for f in log[first + 1 :])
    assert asleep_s == 0.0 < awake_s
    # asleep: zero velocity, and the positions stay exactly where they were
    np.testing.assert_array_equal(solver.state.cur[:, :3], solver.state.prev[:, :3])
    before = solver.state.cur.copy()
    run(solver, 5, first=121)
    np.testing.assert_array_equal(solver.state.cur, before)


def test_falling_cloth_never_sleeps():
    """Faster than the threshold: every test fails and resets the count."""
    solver = make(cook_fabric(grid(16, 16, 0.02)).fabric)  # nothing pinned
    log = run(solver, 40)
    assert not any(f["asleep"] for f in log)
    assert solver.sleep.passes == 0 and solver.sleep.moving


def test_sleep_tests_count_simulated_time(curtain):
    """A cloth that cannot move passes every test: with 0.1 s between tests, 3 passes put it
    to sleep after 0.3 s, i.e. in the 90th iteration = the 18th frame at 300 Hz and 60 fps
    (30 iterations of 1/300 s make one interval despite rounding)."""
    config = SolverConfig(sleep_threshold=0.01, sleep_test_interval=0.1, sleep_after_count=3, frequency=300.0)
    solver = make(curtain, config, initial_velocity=(0.0, 0.0, 0.0))
    solver.state.cur[:, 3] = solver.state.prev[:, 3] = 0.0  # everything pinned
    log = run(solver, 20)
    assert [f["asleep"] for f in log].index(True) == 17


def moving_track(start: float):
    def pose(time: float) -> Pose:
        return Pose(np.eye(3), np.array([max(0.0, time - start) * 0.3, 0.0, 0.0]))

    return pose


def test_a_moving_track_wakes_it_and_keeps_it_awake(curtain):
    solver = make(curtain, track=moving_track(1.0))
    log = run(solver, 60)  # frames 1..60 cover [0, 1) s: the track stands still
    assert log[-1]["asleep"] and solver.sleep.woken_by is None
    sleeping_x = solver.world_points()[:, 0].copy()
    log = run(solver, 30, first=61)  # from 1 s on the track moves at 0.3 m/s
    assert solver.sleep.woken_by == "track"
    assert not any(f["asleep"] for f in log)  # driven every frame: the count keeps restarting
    assert all(f["calls"] == f["iterations"] * len(solver.stages) for f in log)
    moved = solver.world_points()[:, 0] - sleeping_x
    assert moved.mean() > 0.1  # followed the track (0.5 s at 0.3 m/s)


def fake_solver(wind=None, colliders=None, track=None, teleports=frozenset()):
    environment = types.SimpleNamespace(
        wind=wind, colliders=colliders, wind_at=lambda t: np.zeros(3) if wind is None else np.asarray(wind(t))
    )
    return types.SimpleNamespace(environment=environment, track=track, teleport_frames=teleports)


def test_what_wakes_a_cloth():
    plan = FramePlan(frame=10, time=0.5, frame_dt=1 / 60, iterations=5, h=1 / 300, exponent=1 / 3)
    assert driven_by(fake_solver(), plan) is None
    assert driven_by(fake_solver(wind=lambda t: np.array([2.0, 0, 0])), plan) is None
    assert driven_by(fake_solver(wind=lambda t: np.array([t, 0, 0])), plan) == "wind"

    def sphere_at(x):
        return ColliderArrays(
            sphere_center=np.array([[x, 0, 0]], np.float32), sphere_radius=np.ones(1, np.float32),
            sphere_margin=np.zeros(1, np.float32), sphere_friction=np.zeros(1, np.float32),
            sphere_is_collider=np.ones(1, bool),
        )

    assert driven_by(fake_solver(colliders=lambda t: sphere_at(1.0)), plan) is None
    assert driven_by(fake_solver(colliders=lambda t: sphere_at(1.0 if t < 0.51 else 2.0)), plan) == "colliders"
    still = moving_track(1.0)
    assert driven_by(fake_solver(track=still), plan) is None
    assert driven_by(fake_solver(track=moving_track(0.0)), plan) == "track"
    assert driven_by(fake_solver(track=still, teleports=frozenset({10})), plan) == "track"


SCENE = """
[scene]
fps = 60.0
frames = [0, 90]
[solver]
preset = "production"
sleep_threshold = 0.02
sleep_test_interval = 0.05
sleep_after_count = 4
[output]
attributes = []
[track.rail]
time_unit = "seconds"
keys = [{ time = 0.0, translate = [0.0, 0.0, 0.0] }, { time = 1.0, translate = [0.0, 0.0, 0.0] },
        { time = 1.5, translate = [0.2, 0.0, 0.0] }]
[cloth.curtain]
fabric = "curtain.fabric.h5"
material = { preset = "cotton", damping = 0.2 }
track = "rail"
"""


def test_bake_reports_sleeping_frames(curtain, tmp_path):
    folder = tmp_path / "sub"
    folder.mkdir()
    write_fabric(curtain, folder / "curtain.fabric.h5")
    (folder / "scene.toml").write_text(SCENE)
    cache = MemoryCacheWriter()
    stats = bake(load_scene(folder / "scene.toml"), cache)
    asleep = {f["frame"]: f["cloths"]["curtain"]["asleep"] for f in stats.per_frame}
    assert "sleep" in stats.cloths["curtain"]["stages"]
    assert any(asleep[f] for f in range(1, 61))  # still until 1 s (frame 60)
    assert not any(asleep[f] for f in range(61, 91))  # the rail moves from 1 s on
    overall = stats.overall()["curtain"]
    assert overall["asleep_frames"] == sum(asleep.values()) > 0
    # asleep frames are still measured: zero speed, finite
    sleeping = [f["cloths"]["curtain"] for f in stats.per_frame if f["cloths"]["curtain"]["asleep"]]
    assert all(s["max_speed"] == 0.0 and s["finite"] for s in sleeping)
    assert cache.frames[90][0][:, 0].mean() > 0.05  # the curtain went along with the rail
