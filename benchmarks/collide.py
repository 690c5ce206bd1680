"""Collision cost: ms/frame for N x N cloths with each collision feature, and the ratio to the
plain scene (issue 4's benchmark).

    python benchmarks/collide.py [--sizes 64,128] [--frames 60] [--repeats 3]

A 1 m cloth lies flat 0.3 m above the colliders, pinned at two corners, and falls onto them
(so collisions are active for most frames): cotton without air drag, 300 Hz at 60 fps,
null output. Rows: plain; one sphere; the same with continuous collision; self-collision;
a ~10k-triangle mesh collider (a UV sphere); everything at once. Prints the median ms/frame
of the repeats, the ratio to plain, and the stage breakdown of the median run. NvCloth's CPU
solver shows ratios of about 1.3 (sphere), 1.6 (continuous) and 2-3 (self-collision).
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
from pathlib import Path

from clothtool.bake import BakeOptions, bake
from clothtool.cook.cooker import CookOptions, cook_fabric
from clothtool.io.fabric_file import write_fabric
from clothtool.loading import load_scene
from clothtool.mesh.shapes import grid

BASE = """
[scene]
fps = 60.0
frames = [0, {frames}]
[solver]
preset = "production"
frequency = 300.0
continuous_collision = {ccd}
self_collision = {self_collision}
[output]
attributes = []
[cloth.sheet]
fabric = "sheet.fabric.h5"
translate = [-0.5, 0.3, -0.5]
material = {{ preset = "cotton", drag_coefficient = 0.0, lift_coefficient = 0.0, self_collision_distance = {distance} }}
"""
SPHERE = """
[collider.ball]
kind = "sphere"
center = [0.0, 0.0, 0.0]
radius = 0.25
"""
MESH = """
[collider.body]
kind = "mesh"
mesh = "body.obj"
"""

CASES = {
    "plain": dict(colliders="", ccd="false", self_collision="false"),
    "sphere": dict(colliders=SPHERE, ccd="false", self_collision="false"),
    "sphere+continuous": dict(colliders=SPHERE, ccd="true", self_collision="false"),
    "self-collision": dict(colliders="", ccd="false", self_collision="true"),
    "mesh 10k tris": dict(colliders=MESH, ccd="false", self_collision="false"),
    "everything": dict(colliders=SPHERE + MESH, ccd="true", self_collision="true"),
}


def prepare(folder: Path, n: int) -> None:
    import trimesh

    spacing = 1.0 / (n - 1)
    corners = folder / "corners.txt"
    corners.write_text(f"0 {n - 1}\n")
    fabric = cook_fabric(grid(n, n, spacing, plane="XZ"), CookOptions(pin_file=str(corners), tethers="geodesic")).fabric
    write_fabric(fabric, folder / "sheet.fabric.h5")
    body = trimesh.creation.uv_sphere(radius=0.3, count=[72, 72])
    body.apply_translation([0.0, -0.45, 0.0])
    body.export(folder / "body.obj")


def scene(folder: Path, case: dict, frames: int, spacing: float):
    text = BASE.format(frames=frames, ccd=case["ccd"], self_collision=case["self_collision"], distance=0.8 * spacing)
    path = folder / "scene.toml"
    path.write_text(text + case["colliders"])
    return load_scene(path)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", default="64,128")
    parser.add_argument("--frames", type=int, default=60)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    print(f"{'N':>4} {'case':<18} {'ms/frame':>9} {'ratio':>6}  stages (ms/frame)")
    for n in (int(s) for s in args.sizes.split(",")):
        with tempfile.TemporaryDirectory() as tmp:
            folder = Path(tmp)
            prepare(folder, n)
            plain_ms = None
            # a throw-away bake first: thread-pool start-up and first-touch costs land there
            bake(scene(folder, CASES["everything"], 5, 1.0 / (n - 1)), "null")
            for name, case in CASES.items():
                loaded = scene(folder, case, args.frames, 1.0 / (n - 1))
                runs = [bake(loaded, "null", BakeOptions()) for _ in range(args.repeats)]
                runs.sort(key=lambda r: r.simulation_s)
                median = runs[len(runs) // 2]
                ms = 1000 * statistics.median(r.simulation_s for r in runs) / median.frames_simulated
                plain_ms = plain_ms or ms
                stages = " ".join(
                    f"{row['stage']}={row['per_frame_ms']:.2f}" for row in median.profile if row["stage"] != "jit warm-up"
                )
                print(f"{n:>4} {name:<18} {ms:>9.3f} {ms / plain_ms:>6.2f}  {stages}", flush=True)


if __name__ == "__main__":
    main()
