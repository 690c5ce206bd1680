"""The README's walk example (examples/skirt/walk.toml): the legs, tapered capsules of 5-7.5 cm
radius, swing against a skirt of ~5 cm edges. Measured on the baked cache, no face of the
skirt sinks into a leg or the pelvis deeper than the cloth's thickness in any frame; with
particle collision alone (solver.face_collision = false) faces do.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from clothtool.bake import BakeOptions, bake
from clothtool.io.cache import read_cache
from clothtool.loading import load_scene
from clothtool.solver.penetration import face_penetration

WALK = Path(__file__).resolve().parents[2] / "examples" / "skirt" / "walk.toml"
FRAMES = (1, 28)  # the first strides; particle-only faces first sink at frame 17


def cache_penetration(tmp_path: Path, face_collision: bool) -> dict[int, tuple[float, int]]:
    """Per frame of the baked cache: (deepest face point in a collider in m, faces beyond the thickness)."""
    scene = load_scene(WALK, [f"solver.face_collision={str(face_collision).lower()}"], frames=FRAMES)
    cache = tmp_path / f"walk_{face_collision}.h5"
    stats = bake(scene, cache, BakeOptions(penetration=True))
    cloth = scene.cloths[0]
    triangles = cloth.fabric.vertex_numbers(cloth.fabric.triangles)  # the cache is in vertex order
    thickness = cloth.material.thickness
    measured = {}
    with read_cache(cache) as reader:
        assert reader.frames == list(range(FRAMES[0], FRAMES[1] + 1))
        for frame in reader.frames:
            colliders = scene.colliders.at(scene.frame_time(frame))
            result = face_penetration(reader.points(cloth.name, frame), triangles, colliders, scene.meters_per_unit, thickness)
            measured[frame] = (result.depth, result.faces_beyond)
    # the bake's own report agrees with the cache
    per_frame = {f["frame"]: f["cloths"][cloth.name] for f in stats.per_frame}
    for frame, (depth, beyond) in measured.items():
        if frame in per_frame:
            assert per_frame[frame]["faces_beyond_thickness"] == beyond
            assert per_frame[frame]["max_penetration"] == pytest.approx(max(depth, 0.0), abs=1e-6)
    return measured


def test_walk_keeps_every_face_within_the_thickness(tmp_path):
    measured = cache_penetration(tmp_path, face_collision=True)
    thickness = load_scene(WALK).cloths[0].material.thickness
    beyond = {frame: m for frame, m in measured.items() if m[1] > 0 or m[0] > thickness}
    assert not beyond, beyond


def test_walk_with_particle_collision_alone_sinks_faces_into_the_legs(tmp_path):
    measured = cache_penetration(tmp_path, face_collision=False)
    assert sum(beyond > 0 for _, beyond in measured.values()) >= 3
    assert max(depth for depth, _ in measured.values()) > 0.004
