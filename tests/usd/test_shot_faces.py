"""The example shot (examples/shot/shot.usda: a low-poly UsdSkel-skinned body walking in a
skirt of ~5 cm edges). Measured on the baked USD layer over the shot (what `clothtool bake
shot.usda -o cloth.usdc` writes), read back with pxr, no face of the
skirt reaches into the body (grown by its thickness) deeper than the cloth's thickness in any
frame; with particle collision alone (solver.face_collision = false) the body's corners and
ridges poke through the faces between particles."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("pxr")

from pxr import Usd, UsdGeom  # noqa: E402

from clothtool.bake import BakeOptions, bake  # noqa: E402
from clothtool.io.cache import CacheOptions  # noqa: E402
from clothtool.io.usdshot import ShotLayerWriter  # noqa: E402
from clothtool.loading import load_usd_scene  # noqa: E402
from clothtool.solver.penetration import face_penetration  # noqa: E402

SHOT = Path(__file__).resolve().parents[2] / "examples" / "shot" / "shot.usda"


def layer_penetration(tmp_path: Path, face_collision: bool) -> dict[int, tuple[float, int]]:
    """Per frame of the baked layer: (deepest face point in the body in m, faces beyond the thickness)."""
    scene = load_usd_scene(SHOT, [f"solver.face_collision={str(face_collision).lower()}"])
    layer = tmp_path / "sub" / f"shot_{face_collision}.usdc"
    layer.parent.mkdir()
    stats = bake(scene, ShotLayerWriter(layer, scene, CacheOptions()), BakeOptions(penetration=True))
    cloth = scene.cloths[0]
    stage = Usd.Stage.Open(str(layer))
    mesh = UsdGeom.Mesh(stage.GetPrimAtPath(cloth.prim))
    vertex_particle = np.asarray(cloth.vertex_particle)
    triangles = cloth.fabric.vertex_numbers(cloth.fabric.triangles)  # the cook may renumber particles
    measured = {}
    for frame in range(scene.start_frame, scene.end_frame + 1):
        code = Usd.TimeCode(frame)
        local = np.asarray(mesh.GetPointsAttr().Get(code), np.float64)
        matrix = np.array(mesh.ComputeLocalToWorldTransform(code), np.float64)
        particles = np.zeros((cloth.fabric.particle_count, 3))
        particles[vertex_particle] = local @ matrix[:3, :3] + matrix[3, :3]
        colliders = scene.colliders.at(scene.frame_time(frame))
        assert colliders.mesh_triangles.shape[0] > 0  # the body is a mesh collider
        result = face_penetration(
            particles, triangles, colliders, scene.meters_per_unit, cloth.material.thickness * scene.meters_per_unit
        )
        measured[frame] = (result.depth, result.faces_beyond)
    # the bake's own report (world-space solver state) agrees with the layer
    per_frame = {f["frame"]: f["cloths"][cloth.name] for f in stats.per_frame}
    for frame, (depth, beyond) in measured.items():
        if frame in per_frame:
            assert per_frame[frame]["faces_beyond_thickness"] == beyond
            assert per_frame[frame]["max_penetration"] == pytest.approx(max(depth, 0.0), abs=2e-5)
    return measured


def test_shot_keeps_every_face_within_the_thickness(tmp_path):
    measured = layer_penetration(tmp_path, face_collision=True)
    thickness = load_usd_scene(SHOT).cloths[0].material.thickness
    beyond = {frame: m for frame, m in measured.items() if m[1] > 0 or m[0] > thickness}
    assert not beyond, beyond
    assert max(depth for depth, _ in measured.values()) > -0.005  # the skirt does touch the body


def test_shot_with_particle_collision_alone_sinks_faces_into_the_body(tmp_path):
    measured = layer_penetration(tmp_path, face_collision=False)
    assert sum(beyond > 0 for _, beyond in measured.values()) >= 10
