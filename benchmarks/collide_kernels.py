"""Cost of the collide stage: a 64 x 64 cloth dropped onto each kind of collider.

Prints a table of milliseconds per frame (whole frame and the collide stage alone) and the
frame's cost relative to the same cloth without colliders. The mesh colliders are spheres of
2.5k, 10k and 40k triangles: the grid makes the cost grow with the triangles near the cloth,
not with particles x triangles (a brute-force 10k-triangle test would be 4096 x 10k point-
triangle tests per iteration). Static meshes are posed and gridded once; the "moving mesh"
row re-poses and re-grids the 10k mesh every iteration and frame.
Run: ``PYTHONPATH=. python benchmarks/collide_kernels.py``.
"""

from __future__ import annotations

import argparse
import dataclasses
import time

import numpy as np

from clothtool.collision.colliders import ColliderArrays
from clothtool.cook.cooker import CookOptions, cook_fabric
from clothtool.mesh.shapes import grid
from clothtool.profile import StageProfiler
from clothtool.settings import Material, Placement, SolverConfig
from clothtool.solver.cloth import ClothSolver
from clothtool.solver.environment import Environment
from clothtool.solver.model import build_model

FPS = 30.0
GRAVITY = np.array([0.0, -9.81, 0.0])


def sphere_mesh(radius: float, rings: int, segments: int) -> tuple[np.ndarray, np.ndarray]:
    """A UV sphere with its poles on the x axis (the cloth lands on its even middle): (points
    (m,3), triangles (t,3)) with outward (counter-clockwise) winding."""
    theta = np.linspace(0.0, np.pi, rings + 1)[1:-1]
    phi = np.linspace(0.0, 2 * np.pi, segments, endpoint=False)
    t, p = np.meshgrid(theta, phi, indexing="ij")
    ring_points = np.stack([np.cos(t), np.sin(t) * np.cos(p), np.sin(t) * np.sin(p)], axis=-1).reshape(-1, 3)
    points = np.concatenate([[[1.0, 0.0, 0.0]], ring_points, [[-1.0, 0.0, 0.0]]]) * radius
    top, bottom = 0, points.shape[0] - 1
    index = 1 + np.arange((rings - 1) * segments).reshape(rings - 1, segments)
    nxt = np.roll(index, -1, axis=1)
    tris = [np.stack([np.full(segments, top), nxt[0], index[0]], axis=1)]
    a, b, c, d = index[:-1], nxt[:-1], nxt[1:], index[1:]
    tris.append(np.stack([a, b, c], axis=-1).reshape(-1, 3))
    tris.append(np.stack([a, c, d], axis=-1).reshape(-1, 3))
    tris.append(np.stack([np.full(segments, bottom), index[-1], nxt[-1]], axis=1))
    triangles = np.concatenate(tris).astype(np.int32)
    centre = points[triangles].mean(axis=1)
    normal = np.cross(points[triangles[:, 1]] - points[triangles[:, 0]], points[triangles[:, 2]] - points[triangles[:, 0]])
    flip = np.einsum("ij,ij->i", normal, centre) < 0
    triangles[flip] = triangles[flip][:, ::-1]
    return points.astype(np.float32), triangles


def colliders(kind: str, triangles: int = 10000) -> ColliderArrays | None:
    f32 = np.float32
    one = np.ones(1, f32)
    if kind == "none":
        return None
    if kind == "sphere":
        return ColliderArrays(
            sphere_center=np.zeros((1, 3), f32), sphere_radius=one * 0.3, sphere_margin=one * 0.0,
            sphere_friction=one * 0.5, sphere_is_collider=np.ones(1, bool),
        )
    if kind in ("capsule", "capsule ccd"):
        return ColliderArrays(
            sphere_center=np.array([[-0.4, 0.0, 0.0], [0.4, 0.0, 0.0]], f32), sphere_radius=np.array([0.2, 0.1], f32),
            sphere_margin=np.zeros(2, f32), sphere_friction=np.full(2, 0.5, f32), sphere_is_collider=np.zeros(2, bool),
            capsule_spheres=np.array([[0, 1]], np.int32), capsule_margin=one * 0.0, capsule_friction=one * 0.5,
        )
    if kind == "box":
        planes = [(*n, 0.25) for n in np.vstack([np.eye(3), -np.eye(3)])]
        return ColliderArrays(
            plane=np.array(planes, f32), convex_plane_offsets=np.array([0, 6], np.int32),
            convex_margin=one * 0.0, convex_friction=one * 0.5,
        )
    rings = int(round(np.sqrt(triangles / 2)))
    points, tris = sphere_mesh(0.3, rings, rings)
    return ColliderArrays(
        mesh_points=points, mesh_triangles=tris, triangle_mesh=np.zeros(tris.shape[0], np.int32),
        mesh_margin=one * 0.0, mesh_friction=one * 0.5,
    )


def moving(arrays: ColliderArrays):
    """The mesh of ``arrays`` rising at 1 cm/s: re-posed every iteration, re-gridded per frame."""
    def at(time: float) -> ColliderArrays:
        points = arrays.mesh_points + np.float32([0.0, 0.01 * time, 0.0])
        return dataclasses.replace(arrays, mesh_points=points.astype(np.float32))

    return at


def run(fabric, kind: str, frames: int, warm_frames: int, triangles: int = 10000) -> dict:
    arrays = colliders(kind.replace("moving ", ""), triangles)
    if arrays is None:
        call = None
    elif kind.startswith("moving"):
        call = moving(arrays)
    else:
        call = lambda t: arrays  # noqa: E731
    environment = Environment(GRAVITY, colliders=call)
    model = build_model("cloth", fabric, Material(), Placement(), 1.0, "Y")
    config = SolverConfig(continuous_collision=kind == "capsule ccd")
    profiler = StageProfiler()
    solver = ClothSolver(model, config, environment, profiler)
    solver.warm_up()
    for frame in range(warm_frames):  # the cloth falls onto the collider and drapes
        solver.step(frame, frame / FPS, 1.0 / FPS)
    profiler.seconds.clear()
    profiler.calls.clear()
    start = time.perf_counter()
    for frame in range(warm_frames, warm_frames + frames):
        solver.step(frame, frame / FPS, 1.0 / FPS)
    wall = (time.perf_counter() - start) / frames
    collide = profiler.seconds.get("collide", 0.0) / frames
    label = kind if "mesh" not in kind else f"{kind} {arrays.mesh_triangles.shape[0]} tris"
    return {"collider": label, "frame_ms": 1000 * wall, "collide_ms": 1000 * collide}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=64, help="cloth particles per side [64]")
    parser.add_argument("--frames", type=int, default=20, help="timed frames per run [20]")
    parser.add_argument("--warm-frames", type=int, default=15, help="frames before timing [15]")
    args = parser.parse_args()
    n = args.size
    mesh = grid(n, n, 1.0 / (n - 1), plane="XZ", origin=(-0.5, 0.35, -0.5))
    fabric = cook_fabric(mesh, CookOptions()).fabric
    rows = [run(fabric, "none", args.frames, args.warm_frames)]
    for kind in ("sphere", "capsule", "capsule ccd", "box"):
        rows.append(run(fabric, kind, args.frames, args.warm_frames))
    for triangles in (2500, 10000, 40000):
        rows.append(run(fabric, "mesh", args.frames, args.warm_frames, triangles))
    rows.append(run(fabric, "moving mesh", args.frames, args.warm_frames, 10000))
    base = rows[0]["frame_ms"]
    print(f"{n}x{n} cloth, {SolverConfig().frequency:g} Hz, {FPS:g} fps; times per frame")
    print(f"{'collider':<22}{'frame ms':>10}{'collide ms':>12}{'x no-collider':>15}")
    for row in rows:
        print(f"{row['collider']:<22}{row['frame_ms']:>10.2f}{row['collide_ms']:>12.2f}{row['frame_ms'] / base:>15.2f}")


if __name__ == "__main__":
    main()
