"""The position-based solver's compiled frame function (clothtool.solver.framefn) against its
stage-by-stage path (what ``--profile`` runs): the same bits, in both state precisions, with
every collider kind, self-collision, sleep, wind, a moving frame, and at any thread count."""

from __future__ import annotations

import numba
import numpy as np
import pytest

from clothtool.bake import BakeOptions, bake
from clothtool.cook.cooker import CookOptions, cook_fabric
from clothtool.io.fabric_file import write_fabric
from clothtool.io.memory import MemoryCacheWriter
from clothtool.loading import load_scene
from clothtool.mesh.shapes import grid
from tests.conftest import EXAMPLES

# A sheet dropped onto a sphere, a mesh bump, a box and the floor; a capsule passes above it on
# a track. It self-collides, feels air drag and falls asleep once it lies still.
DROP = """
[scene]
fps = 60.0
frames = [0, 160]  # the free sheet (damped relative to its mean motion) falls asleep at ~143
[solver]
preset = "production"
frequency = 300.0
self_collision = true
sleep_threshold = 0.1
sleep_test_interval = 0.05
sleep_after_count = 3
[output]
attributes = ["velocities", "stats"]
[cloth.sheet]
fabric = "sheet.fabric.h5"
translate = [-0.4, 0.35, -0.4]
material = { preset = "cotton", self_collision_distance = 0.02 }
[collider.ball]
kind = "sphere"
center = [0.0, 0.0, 0.0]
radius = 0.2
[collider.bump]
kind = "mesh"
mesh = "bump.obj"
[collider.box]
kind = "convex"
box = { center = [0.3, -0.15, 0.3], size = [0.2, 0.2, 0.2] }
[collider.floor]
kind = "plane"
point = [0, -0.2, 0]
[collider.arm]
kind = "capsule"
start = [0, 0, -0.5]
end = [0, 0, 0.5]
radii = [0.05, 0.04]
track = "sweep"
[track.sweep]
keys = [{ time = 0, translate = [-0.8, 0.8, 0.0] }, { time = 30, translate = [0.8, 0.8, 0.0] }]
"""


@pytest.fixture(scope="module")
def drop_scene(tmp_path_factory):
    folder = tmp_path_factory.mktemp("drop")
    fabric = cook_fabric(grid(12, 12, 0.8 / 11, plane="XZ"), CookOptions(tethers="none")).fabric
    write_fabric(fabric, folder / "sheet.fabric.h5")
    corners = np.array([[-0.15, -0.2, -0.15], [0.15, -0.2, -0.15], [0.15, -0.2, 0.15], [-0.15, -0.2, 0.15],
                        [0.0, -0.05, 0.0]])
    faces = [[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]]
    lines = [f"v {x:.6f} {y:.6f} {z:.6f}" for x, y, z in corners] + [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in faces]
    (folder / "bump.obj").write_text("\n".join(lines) + "\n")
    (folder / "scene.toml").write_text(DROP)
    return folder / "scene.toml"


class FrameRecorder(MemoryCacheWriter):
    """Keeps every frame's data as the bake made it (points and velocities in their dtype, stats)."""

    def _keep(self, frame) -> None:
        self.frames[frame.frame] = frame


def _bake(path, overrides, profile_stages: bool, frames=None):
    writer = FrameRecorder()
    stats = bake(load_scene(path, overrides, frames=frames), writer, BakeOptions(profile_stages=profile_stages))
    return writer, stats


def _assert_same_frames(compiled: FrameRecorder, staged: FrameRecorder) -> None:
    assert compiled.frames.keys() == staged.frames.keys()
    for frame in compiled.frames:
        a, b = compiled.frames[frame], staged.frames[frame]
        arrays = [(x, y) for x, y in zip(a.points, b.points)]
        if a.velocities is not None or b.velocities is not None:
            arrays += list(zip(a.velocities, b.velocities))
        for mine, theirs in arrays:
            assert mine.dtype == theirs.dtype and mine.tobytes() == theirs.tobytes(), f"frame {frame} differs"
        assert a.stats == b.stats


def _assert_same_bake(compiled, staged) -> None:
    (writer_c, stats_c), (writer_s, stats_s) = compiled, staged
    _assert_same_frames(writer_c, writer_s)
    assert stats_c.per_frame == stats_s.per_frame  # the stats (strain, speed, energy, sleep) of every frame
    # the compiled bake ran frames whole; the staged one timed every stage
    assert "frame" in {row["stage"] for row in stats_c.profile}
    staged_rows = {row["stage"] for row in stats_s.profile}
    assert "frame" not in staged_rows and set(stats_s.stages) <= staged_rows


@pytest.mark.parametrize("precision", ["float32", "float64"])
def test_walk_compiled_frames_match_the_stage_by_stage_bake(precision):
    overrides = [f"solver.precision={precision}"]
    path = EXAMPLES / "skirt" / "walk.toml"
    compiled = _bake(path, overrides, False, frames=(1, 13))
    staged = _bake(path, overrides, True, frames=(1, 13))
    assert {"integrate", "wind", "collide"} <= set(compiled[1].stages)
    _assert_same_bake(compiled, staged)


@pytest.mark.parametrize("precision", ["float32", "float64"])
def test_drop_compiled_frames_match_the_stage_by_stage_bake(drop_scene, precision):
    overrides = [f"solver.precision={precision}"]
    compiled = _bake(drop_scene, overrides, False)
    staged = _bake(drop_scene, overrides, True)
    assert {"integrate", "wind", "fabric", "collide", "self-collide", "sleep"} <= set(compiled[1].stages)
    # the sheet fell asleep during the bake: the frame function's early return was taken
    asleep = [f["cloths"]["sheet"]["asleep"] for f in compiled[1].per_frame]
    assert asleep[-1] and not asleep[0]
    _assert_same_bake(compiled, staged)


def test_drop_compiled_frames_are_the_same_at_any_thread_count(drop_scene):
    # every parallel kernel variant in use: the fabric's sets, collision and self-collision
    overrides = ["solver.parallel_threshold=1", "solver.fabric_parallel_threshold=1"]
    if numba.config.NUMBA_NUM_THREADS < 2:
        pytest.skip("numba has a single thread on this machine")
    before = numba.get_num_threads()
    try:
        numba.set_num_threads(1)
        one = _bake(drop_scene, overrides, False, frames=(0, 30))
        numba.set_num_threads(min(2, numba.config.NUMBA_NUM_THREADS))
        two = _bake(drop_scene, overrides, False, frames=(0, 30))
        staged = _bake(drop_scene, overrides, True, frames=(0, 30))
    finally:
        numba.set_num_threads(before)
    _assert_same_frames(one[0], two[0])
    _assert_same_bake(two, staged)


def test_walk_caches_are_byte_identical(tmp_path):
    path = EXAMPLES / "skirt" / "walk.toml"
    outputs = []
    for profile_stages in (False, True):
        output = tmp_path / f"walk_{profile_stages}.h5"
        bake(load_scene(path, frames=(1, 7)), output, BakeOptions(profile_stages=profile_stages))
        outputs.append(output.read_bytes())
    assert outputs[0] == outputs[1]
