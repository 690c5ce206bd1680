"""What the compiled frame's preparation keeps from frame to frame (clothtool.solver.framefn
FusedFrame.prepare, CollideStage.fused_call): kept while its inputs are the same objects,
made again when one changes, and always the values a fresh preparation gives."""

from __future__ import annotations

import numpy as np
import pytest

from clothtool.bake import make_solvers
from clothtool.loading import load_scene
from clothtool.profile import StageProfiler
from clothtool.solver.framefn import FusedFrame
from tests.conftest import EXAMPLES


@pytest.fixture(scope="module")
def walk():
    """The walk's cloth planned through its first three frames (a track, capsules, wind)."""
    scene = load_scene(EXAMPLES / "skirt" / "walk.toml")
    solver = make_solvers(scene, StageProfiler())[0]
    frame_dt = 1.0 / scene.fps
    plans = []
    for frame in range(scene.start_frame + 1, scene.start_frame + 4):
        plans.append(solver.plan_frame(frame, scene.frame_time(frame - 1), frame_dt, scene.frame_time(frame)))
    return solver, plans


def _stage(solver, name):
    return next(stage for stage in solver.stages if stage.name == name)


def _fresh(solver):
    """The function and values a new FusedFrame prepares (nothing kept)."""
    function, values, new = FusedFrame().prepare(solver.stages)
    assert new
    return function, values


def _same_values(a: list, b: list) -> bool:
    return len(a) == len(b) and all(
        np.array_equal(x, y) and np.asarray(x).dtype == np.asarray(y).dtype if isinstance(x, np.ndarray) else x == y
        for x, y in zip(a, b)
    )


def test_collide_call_is_kept_while_its_arrays_stand_and_made_again_when_one_changes(walk):
    solver, plans = walk
    collide = _stage(solver, "collide")
    first = collide.fused_call()
    collide.begin_frame(plans[-1])  # refills the arrays in place
    assert collide.fused_call() is first
    frames = collide.frames
    collide.frames = frames.copy()  # another array (as a new iteration count would give)
    changed = collide.fused_call()
    assert changed is not first
    assert changed.args["frames"] is collide.frames
    collide.frames = frames
    assert collide.fused_call().args["frames"] is frames


def _frames(count: int, scene_file: str = "walk.toml"):
    """The bundled skirt scene's cloth simulated frame by frame (compiled frames), yielding
    after each frame's plan: (solver, plan)."""
    scene = load_scene(EXAMPLES / "skirt" / scene_file)
    solver = make_solvers(scene, StageProfiler())[0]
    frame_dt = 1.0 / scene.fps
    for frame in range(scene.start_frame + 1, scene.start_frame + 1 + count):
        plan = solver.plan_frame(frame, scene.frame_time(frame - 1), frame_dt, scene.frame_time(frame))
        yield solver, plan
        assert solver.run_frame(plan)


def test_moving_frame_calls_stand_from_frame_to_frame_with_their_rows_moving_on():
    """The integrate, wind and collide calls of a cloth on a track are the same objects every
    frame of the path computed ahead, their per-iteration values rows of the frame motion's
    stacks from the frame's row on (only the row arrays' value moves), so prepare finds every
    call standing and gives the last frame's values list again."""
    last, kept = None, FusedFrame()
    for solver, plan in _frames(4):
        calls = {stage.name: stage.fused_call() for stage in solver.stages}
        k, terms = plan.iterations, solver.frame_terms
        first = int(calls["integrate"].args["row"][0])
        assert all(int(calls[name].args["row"][0]) == first for name in ("wind", "collide"))
        integrate, wind, collide = calls["integrate"].args, calls["wind"].args, calls["collide"].args
        assert np.array_equal(integrate["m_cur"][first : first + k], terms.m_cur)
        assert np.array_equal(integrate["m_prev"][first : first + k], terms.m_prev)
        assert np.array_equal(integrate["bias"][first : first + k], terms.bias)
        assert np.array_equal(wind["matrix"][first : first + k], terms.motion_matrix)
        assert np.array_equal(wind["offset"][first : first + k], terms.motion_offset)
        air = terms.in_frame(_stage(solver, "wind").wind_world, np.float32)
        assert np.array_equal(wind["air"][first : first + k], air)
        assert np.array_equal(collide["frames"][first : first + k], terms.pose_pairs)
        values = kept.prepare(solver.stages)[1]
        if last is not None:
            last_calls, last_values, last_first = last
            assert first == last_first + k
            assert all(calls[name] is last_calls[name] for name in calls)
            assert values is last_values
        last = calls, values, first


def test_prepare_gives_a_fresh_preparations_function_and_values_every_frame(walk):
    solver, plans = walk
    kept = FusedFrame()
    for number, plan in enumerate(plans):
        for stage in solver.stages:
            stage.begin_frame(plan)
        function, values, new = kept.prepare(solver.stages)
        assert new == (number == 0)
        fresh_function, fresh_values = _fresh(solver)
        assert function is fresh_function
        assert _same_values(values, fresh_values)
        # the values are the stages' current arrays themselves, not copies
        assert all(a is b for a, b in zip(values, fresh_values) if isinstance(a, np.ndarray))


def test_prepare_follows_a_stage_that_changes_its_kernel(walk):
    solver, plans = walk
    kept = FusedFrame()
    function, _, _ = kept.prepare(solver.stages)
    collide = _stage(solver, "collide")
    kernel = collide.kernel
    other = collide.virtual_kernel if collide.virtual_kernel is not kernel else None
    assert other is not None
    try:
        collide.kernel = other  # another kernel: another frame function
        changed, _, new = kept.prepare(solver.stages)
        assert new and changed is not function
        assert changed is _fresh(solver)[0]
    finally:
        collide.kernel = kernel
    back, _, new = kept.prepare(solver.stages)
    assert back is function and new


def test_calls_stand_without_a_track_in_a_steady_wind():
    """Without a track the wind stage keeps its air in the same array (framefn.held) and its
    zero frame motion: from the second frame on every call stands, so prepare gives the
    last frame's values list again; the air rows are the wind's displacement per iteration."""
    last, kept = None, FusedFrame()
    for solver, plan in _frames(3, "scene.toml"):
        assert solver.frame_terms is None
        calls = [stage.fused_call() for stage in solver.stages]
        values = kept.prepare(solver.stages)[1]
        wind = _stage(solver, "wind")
        expected = np.broadcast_to(wind.wind_world, (plan.iterations, 3)).astype(np.float32)
        assert int(wind.row[0]) == 0 and np.array_equal(wind.air, expected) and not wind.matrix.any()
        if last is not None:
            assert all(a is b for a, b in zip(calls, last[0])) and values is last[1]
        last = calls, values

