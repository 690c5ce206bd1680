"""The solver-core issue's table: clothtool against NvCloth's native CPU solver, same scenes.

    python benchmarks/nvcloth_table.py [--nvbench PATH] [--frames 100] [--repeats 3]
                                       [--rows plain,garment,sphere,self] [--work DIR]

Prints one line per scene with clothtool's CPU ms per frame through the solver loop (as
``bake()`` drives it: plan_frame, then iterate) and through ``bake()`` itself (default per-frame
stats, null writer), and, given ``--nvbench`` (the harness binary built from NvCloth's public
source, see ``shared/nvcloth-bench/README.md``), NvCloth's CPU ms per frame for the same scene
and the ratios clothtool / NvCloth. Runs are interleaved (clothtool loop, bake, NvCloth, then
again) and each figure is the median of the repeats, in process CPU time after JIT warm-up.

Scenes (those of the shared harness): an N x N hanging cloth 1 m across pinned at its two
top corners, geodesic tethers, cotton without air drag, production solver:

* plain: 32^2, 64^2, 128^2, 255^2 at 300 Hz and 60 fps (5 iterations per frame);
* garment: 16^2, 32^2 at 312 Hz and 24 fps (13 iterations per frame), plain and with three
  capsules cutting into the sheet: with clothtool's default face collision (each triangle too
  large for the capsules pushes its deepest point out of them, clothtool.solver.kernels.collide_faces,
  which NvCloth does not have) and with particles only (``face_collision = false``: NvCloth's model);
* sphere: 64^2, 128^2 draped on a sphere, without and with continuous collision;
* self: 64^2, 128^2 with self-collision.

NvCloth gets the same particles (in clothtool's particle order), inverse masses and
triangles (``mesh.bin``) and every setting read back from clothtool's loaded scene, mapped one
to one onto NvCloth's setters (``nv.cfg``); its own cooker builds its fabric and tethers.
NvCloth limits a cloth to 65,532 particles, so 255^2 is the largest grid.
"""

from __future__ import annotations

import argparse
import json
import statistics
import struct
import subprocess
import tempfile
import time
from pathlib import Path

import numpy as np

from clothtool.bake import bake, make_solvers
from clothtool.cook.cooker import CookOptions, cook_fabric
from clothtool.io.fabric_file import write_fabric
from clothtool.loading import load_scene
from clothtool.mesh.shapes import grid
from clothtool.profile import StageProfiler

SPHERE = dict(center=(0.5, -1.1, 0.05), radius=0.3)
# two "legs" and a "body" 0.05-0.08 m in front of the sheet's plane, so that they cut into it
CAPSULES = [
    dict(start=(0.2, -0.7, 0.05), end=(0.2, -1.2, 0.05), radius=0.08),
    dict(start=(0.8, -0.7, 0.05), end=(0.8, -1.2, 0.05), radius=0.08),
    dict(start=(0.3, -0.4, 0.08), end=(0.7, -0.4, 0.08), radius=0.1),
]
# name: (sphere, capsules, continuous collision, self-collision, face collision)
VARIANTS = {
    "plain": (False, False, False, False, True),
    "sphere": (True, False, False, False, True),
    "sphere+ccd": (True, False, True, False, True),
    "capsules": (False, True, False, False, True),
    # NvCloth's own collision model: particles only (clothtool's default also collides the
    # faces: the deepest point of each triangle too large for the capsules, more work)
    "capsules, particles only": (False, True, False, False, False),
    "self": (False, False, False, True, True),
}
# table section -> (label, sizes, variants, fps, solver frequency)
ROWS = {
    "plain": [("plain hanging cloth, 5 it/frame", (32, 64, 128, 255), ("plain",), 60.0, 300.0)],
    "garment": [("garment, 13 it/frame", (16, 32), ("plain", "capsules", "capsules, particles only"), 24.0, 312.0)],
    "sphere": [("sphere, 5 it/frame", (64, 128), ("sphere", "sphere+ccd"), 60.0, 300.0)],
    "self": [("self-collision, 5 it/frame", (64, 128), ("self",), 60.0, 300.0)],
}

SCENE = """
[scene]
fps = {fps}
frames = [0, {frames}]
[solver]
preset = "production"
frequency = {frequency}
precision = "{precision}"
continuous_collision = {ccd}
self_collision = {self_collision}
face_collision = {face_collision}
[output]
attributes = ["stats"]
[cloth.sheet]
fabric = "sheet.fabric.h5"
material = {{ preset = "cotton", drag_coefficient = 0.0, lift_coefficient = 0.0, friction = 0.5, damping = 0.1, self_collision_distance = {distance} }}
"""


def _vec(values) -> str:
    return "[" + ", ".join(repr(float(v)) for v in values) + "]"


def prepare(folder: Path, n: int, variant: str, fps: float, frequency: float, frames: int,
            precision: str = "float64") -> None:
    """Write the scene for clothtool (scene.toml, sheet.fabric.h5) and for nvbench (mesh.bin,
    nv.cfg) into ``folder``."""
    sphere, capsules, ccd, self_collision, face_collision = VARIANTS[variant]
    folder.mkdir(parents=True, exist_ok=True)
    spacing = 1.0 / (n - 1)
    mesh = grid(n, n, spacing)
    pin = np.zeros(n * n, np.float32)
    pin[[0, n - 1]] = 1.0
    fabric = cook_fabric(mesh.replace(vertex_attrs={"pin": pin}), CookOptions(pin_attr="pin", tethers="geodesic")).fabric
    write_fabric(fabric, folder / "sheet.fabric.h5")
    text = SCENE.format(
        fps=fps, frames=frames, frequency=frequency, precision=precision, ccd=str(ccd).lower(), self_collision=str(self_collision).lower(),
        face_collision=str(face_collision).lower(),
        distance=0.75 * spacing if self_collision else 0.0,
    )
    if sphere:
        text += f'[collider.ball]\nkind = "sphere"\ncenter = {_vec(SPHERE["center"])}\nradius = {SPHERE["radius"]}\n'
    for k, cap in enumerate(CAPSULES if capsules else []):
        text += (f'[collider.cap{k}]\nkind = "capsule"\nstart = {_vec(cap["start"])}\nend = {_vec(cap["end"])}\n'
                 f'radius = {cap["radius"]}\n')
    (folder / "scene.toml").write_text(text)

    # every NvCloth setting is read back from clothtool's own loaded scene
    scene = load_scene(folder / "scene.toml")
    model = make_solvers(scene, StageProfiler())[0].model
    material, config = model.material, scene.solver
    with open(folder / "mesh.bin", "wb") as f:  # particles in clothtool's order, both tools alike
        triangles = fabric.triangles.astype("<u4")
        f.write(struct.pack("<ii", model.particle_count, triangles.shape[0]))
        f.write(model.rest_pos.astype("<f4").tobytes())
        f.write(model.inv_mass.astype("<f4").tobytes())
        f.write(triangles.tobytes())
    iterations = max(1, int(config.frequency / scene.fps + 0.5))
    h = 1.0 / scene.fps / iterations
    gravity = np.asarray(scene.gravity, np.float64)
    margin = material.thickness / model.units_to_meters
    cfg = {
        "frames": frames, "dt": 1.0 / scene.fps, "solver_frequency": config.frequency,
        "stiffness_frequency": config.stiffness_frequency, "gravity": list(gravity),
        "prev_offset": list(0.5 * gravity * h * h), "damping": material.damping,
        "tether_stiffness": material.tether_stiffness, "tether_scale": material.tether_scale,
        "tethers_per_particle": 1, "quadify": 1,
    }
    for label in ("vertical", "horizontal", "shearing", "bending"):
        p = material.phase(label)
        cfg[f"phase_{label}"] = [p.stiffness, p.stiffness_multiplier, p.compression_limit, p.stretch_limit]
    spheres, caps = [], []
    if sphere:
        spheres += [*SPHERE["center"], SPHERE["radius"] + margin]
    for cap in CAPSULES if capsules else []:
        k = len(spheres) // 4
        spheres += [*cap["start"], cap["radius"] + margin, *cap["end"], cap["radius"] + margin]
        caps += [k, k + 1]
    if spheres:
        cfg.update(spheres=spheres, friction=material.friction, collision_mass_scale=material.collision_mass_scale,
                   continuous_collision=int(config.continuous_collision))
    if caps:
        cfg["capsules"] = caps
    if config.self_collision:
        cfg["self_collision_distance"] = material.self_collision_distance / model.units_to_meters
        cfg["self_collision_stiffness"] = material.self_collision_stiffness
    with open(folder / "nv.cfg", "w") as f:
        for key, value in cfg.items():
            values = value if isinstance(value, list) else [value]
            f.write(key + " " + " ".join(repr(float(v)) for v in values) + "\n")


def clothtool_loop(folder: Path) -> float:
    """CPU ms per frame of the solver loop exactly as bake() drives it, after JIT warm-up."""
    scene = load_scene(folder / "scene.toml")
    solvers = make_solvers(scene, StageProfiler())
    for solver in solvers:
        solver.warm_up()
    frame_dt = 1.0 / scene.fps
    cpu0 = time.process_time()
    for frame in range(scene.start_frame + 1, scene.end_frame + 1):
        plans = [s.plan_frame(frame, scene.frame_time(frame - 1), frame_dt, scene.frame_time(frame)) for s in solvers]
        for index in range(max(p.iterations for p in plans)):
            for solver, plan in zip(solvers, plans):
                if index < plan.iterations:
                    solver.iterate(solver.iteration(plan, index))
    return 1000.0 * (time.process_time() - cpu0) / (scene.end_frame - scene.start_frame)


def clothtool_bake(folder: Path) -> float:
    """CPU ms per frame of bake(scene, "null") with its per-frame stats, after a two-frame
    bake has compiled (or loaded) every kernel it needs: the timed bake's warm-up is then
    short, and is subtracted as bake() reports it."""
    bake(load_scene(folder / "scene.toml", frames=(0, 2)), "null")
    stats = bake(load_scene(folder / "scene.toml"), "null")
    return 1000.0 * (stats.cpu_s - stats.jit_s) / stats.frames_simulated


def nvcloth(binary: Path, folder: Path) -> float:
    """NvCloth's CPU ms per frame (the harness times its simulate loop only)."""
    out = subprocess.run([str(binary), str(folder)], capture_output=True, text=True, check=True, cwd=folder)
    result = json.loads(out.stdout.strip().splitlines()[-1])
    if not result["finite"]:
        raise RuntimeError(f"NvCloth went unstable on {folder.name}")
    return float(result["cpu_ms_per_frame"])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--nvbench", type=Path, help="the harness binary (shared/nvcloth-bench/build.sh)")
    parser.add_argument("--frames", type=int, default=100)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--rows", default="plain,garment,sphere,self", help=f"sections: {','.join(ROWS)}")
    parser.add_argument("--precision", choices=("float64", "float32"), default="float64",
                        help="clothtool's particle state (NvCloth's is float32; the default is clothtool's)")
    parser.add_argument("--work", type=Path, help="keep the scenes here (default: a temporary folder)")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        work = args.work or Path(tmp)
        nv_header = " | NvCloth | loop / NvCloth | bake / NvCloth" if args.nvbench else ""
        print(f"CPU ms per frame, median of {args.repeats} interleaved runs, {args.frames} frames, "
              f"clothtool state in {args.precision}")
        print(f"| scene | N | clothtool loop | clothtool bake(){nv_header} |")
        print("|---|---|---|---" + ("|---|---|---" if args.nvbench else "") + "|")
        for section in args.rows.split(","):
            for label, sizes, variants, fps, frequency in ROWS[section]:
                for variant in variants:
                    for n in sizes:
                        folder = work / f"{section}-{variant.replace(', ', '-').replace(' ', '-')}-{n}"
                        prepare(folder, n, variant, fps, frequency, args.frames, args.precision)
                        runs = {"loop": [], "bake": [], "nv": []}
                        for _ in range(args.repeats):
                            runs["loop"].append(clothtool_loop(folder))
                            runs["bake"].append(clothtool_bake(folder))
                            if args.nvbench:
                                runs["nv"].append(nvcloth(args.nvbench.resolve(), folder))
                        loop, baked = statistics.median(runs["loop"]), statistics.median(runs["bake"])
                        cells = f"| {label} ({variant}) | {n} | {loop:.3f} | {baked:.3f}"
                        if args.nvbench:
                            nv = statistics.median(runs["nv"])
                            cells += f" | {nv:.3f} | {loop / nv:.2f} | {baked / nv:.2f}"
                        print(cells + " |", flush=True)


if __name__ == "__main__":
    main()
