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


def test_collide_frames_hold_the_planned_pose_pairs(walk):
    solver, plans = walk
    collide = _stage(solver, "collide")
    collide.begin_frame(plans[-1])
    # a copy in the stage's own array, bit for bit the frame terms' pose pairs
    assert collide.frames is not solver.frame_terms.pose_pairs
    assert np.array_equal(collide.frames, solver.frame_terms.pose_pairs)
    assert collide.pose_mesh.shape == (plans[-1].iterations,) and not collide.pose_mesh.any()


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
