"""Compile every kernel variant into the kernel cache (``clothtool warmup``), once, e.g. when
a CI image or a render node is built, so that no bake pays for compilation later.

There is no second list of kernels or signatures here: the warm-up bakes a tiny scene (a few
dozen particles, two frames, every collider kind, wind, motion constraints, a backstop, two
cloths that collide with each other and with themselves; the cloth that follows a track does
so only for the position-based solver, the others simulate in world space) through the ordinary ``bake`` path,
once per solver variant: each integrator, each precision and stiffness mode, and each with
the parallel thresholds at their defaults (serial kernels) and at 1 (parallel kernels). A
bake compiles exactly what a scene of that variant needs, so together they compile all.
"""

from __future__ import annotations

import dataclasses
import itertools
import tempfile
import time
from pathlib import Path
from typing import Callable

import numpy as np

from clothtool.bake import BakeOptions, bake
from clothtool.errors import UnstableError
from clothtool.io.extent_kernel import frame_extent
from clothtool.io.h5chunks import GzipChunkEncoder
from clothtool.loading import load_scene
from clothtool.sim.integrators import CAPABILITIES, integrator_spec
from clothtool.solver.kernels.rows import gather_xyz, vertex_rows

GRID = 6  # particles per side of the warm-up cloths

SCENE = """\
version = 1

[scene]
name = "warmup"
fps = 24.0
frames = [1, 2]

[solver]
preset = "production"
self_collision = true
continuous_collision = true
cloth_collision = true
sleep_threshold = 0.001

[output]
attributes = ["velocities", "rest", "stats", "colliders"]

[wind]
velocity = [1.0, 0.0, 0.5]
track = "gusts"

[track.gusts]
keys = [{ time = 1, translate = [0.0, 0.0, 0.0] }, { time = 2, translate = [0.5, 0.0, 0.0] }]

[track.hips]
interpolation = "cubic"
keys = [{ time = 1, translate = [0.0, 0.0, 0.0] }, { time = 2, translate = [0.0, 0.0, 0.1], rotate_euler = [0.0, 10.0, 0.0] }]

[cloth.front]
mesh = "grid.obj"
cook = { pin_box = [-0.01, -0.01, -0.01, 1.01, 0.01, 0.01] }
material = "cotton"
{front_track}translate = [-0.5, 1.0, 0.0]
motion = { scale = 1.0, bias = 0.0, stiffness = 1.0 }
backstop = { radius = 0.5, distance = 0.02 }

[cloth.back]
mesh = "grid.obj"
cook = { pin_box = [-0.01, -0.01, -0.01, 1.01, 0.01, 0.01], tethers = "none" }
material = "silk"
translate = [-0.5, 1.0, 0.05]

[collider.ball]
kind = "sphere"
center = [0.0, 0.5, 0.0]
radius = 0.1
track = "hips"

[collider.leg]
kind = "capsule"
start = [0.2, 0.0, 0.0]
end = [0.2, 0.5, 0.0]
radii = [0.05, 0.04]

"""

CONVEX_COLLIDERS = """
[collider.floor]
kind = "plane"
point = [0.0, -1.0, 0.0]

[collider.box]
kind = "convex"
box = { center = [-0.3, 0.2, 0.0], size = [0.1, 0.1, 0.1] }
"""

MESH_COLLIDERS = """
[collider.ramp]
kind = "mesh"
mesh = "grid.obj"
track = "hips"
"""


# The warm-up scene's lines that ask for a capability: left out for an integrator without it
# (a scene asking for what its integrator lacks is refused, clothtool.sim.integrators).
CAPABILITY_LINES = {
    "self_collision = true": "self_collision",
    "cloth_collision = true": "cloth_collision",
    "sleep_threshold = ": "sleep",
    "motion = { ": "motion",
    "backstop = { ": "separation",
}


@dataclasses.dataclass(frozen=True)
class Variant:
    """One solver configuration to bake: ``overrides`` are scene ``--set`` strings."""

    label: str
    overrides: tuple[str, ...]
    tracked: bool  # a cloth simulates in a moving frame (the position-based solver only)
    convexes: bool = True  # plane and convex colliders besides the spheres and capsules
    meshes: bool = True  # a mesh collider
    capabilities: frozenset[str] = frozenset(CAPABILITIES)  # what the variant's integrator does

    def scene_text(self) -> str:
        text = SCENE.replace("{front_track}", 'track = "hips"\n' if self.tracked else "")
        lines = [
            line for line in text.splitlines(keepends=True)
            if all(capability in self.capabilities for start, capability in CAPABILITY_LINES.items() if line.startswith(start))
        ]
        return "".join(lines) + (CONVEX_COLLIDERS if self.convexes else "") + (MESH_COLLIDERS if self.meshes else "")


def variants() -> list[Variant]:
    """Every integrator x precision (x stiffness mode for the position-based one) x
    serial / parallel kernels, with every collider kind; then, for the position-based solver,
    every other combination of mesh colliders, convex colliders and continuous collision (its
    particle collision kernel is compiled for the kinds a scene has)."""
    found = []
    threading = {"serial": (), "parallel": ("solver.parallel_threshold=1", "solver.fabric_parallel_threshold=1")}
    modes = {"pbd": ("nvcloth", "xpbd"), "implicit": (None,), "explicit": (None,)}
    for integrator, modes_of in modes.items():
        for mode, precision, (threads, thread_overrides) in itertools.product(
            modes_of, ("float32", "float64"), threading.items()
        ):
            overrides = [f'solver.integrator="{integrator}"', f'solver.precision="{precision}"', *thread_overrides]
            if mode is not None:
                overrides.append(f'solver.stiffness_mode="{mode}"')
            if integrator == "explicit":  # the preset's frequency is beyond its stability limit for this cloth
                overrides.append("solver.force=true")
            label = " ".join(part for part in (integrator, mode, precision, threads) if part)
            capabilities = integrator_spec(integrator).capabilities
            found.append(Variant(label, tuple(overrides), tracked="tracks" in capabilities, capabilities=capabilities))
    for precision, (threads, thread_overrides) in itertools.product(("float32", "float64"), threading.items()):
        for meshes, convexes, continuous in itertools.product((True, False), repeat=3):
            if meshes and convexes and continuous:
                continue  # above
            kinds = [name for name, on in (("mesh", meshes), ("convex", convexes), ("continuous", continuous)) if on]
            overrides = ['solver.integrator="pbd"', f'solver.precision="{precision}"', *thread_overrides,
                         f"solver.continuous_collision={str(continuous).lower()}"]
            label = f"pbd {precision} {threads} colliders: spheres capsules {' '.join(kinds)}".rstrip()
            found.append(Variant(label, tuple(overrides), tracked=True, convexes=convexes, meshes=meshes))
    return found


def _grid_obj(n: int) -> str:
    """An n x n particle grid in the XY plane, 1 unit wide, as OBJ text."""
    coords = np.linspace(0.0, 1.0, n)
    lines = [f"v {x:.6f} {y:.6f} 0.0" for y in coords for x in coords]
    for row, col in itertools.product(range(n - 1), range(n - 1)):
        a = row * n + col + 1
        lines.append(f"f {a} {a + 1} {a + n + 1} {a + n}")
    return "\n".join(lines) + "\n"


def warm_up_kernels(
    report: Callable[[str, float], None] = lambda label, seconds: None, only: Callable[[Variant], bool] = lambda v: True
) -> float:
    """Bake the warm-up scene once per variant (compiling into, or loading from, the kernel
    cache); ``report(label, seconds)`` after each; ``only`` selects variants. Returns the total
    seconds."""
    total = 0.0
    with tempfile.TemporaryDirectory(prefix="clothtool-warmup-") as tmp:
        folder = Path(tmp)
        (folder / "grid.obj").write_text(_grid_obj(GRID))
        scene_path = folder / "warmup.toml"
        for variant in filter(only, variants()):
            start = time.perf_counter()
            scene_path.write_text(variant.scene_text())
            scene = load_scene(scene_path, list(variant.overrides))
            try:
                # the options of the command line's bakes: their measures compile too (the
                # face penetration of spheres and capsules, and of meshes)
                bake(scene, "null", BakeOptions(percentiles=True, penetration=True))
            except UnstableError:
                pass  # raised after the frame was simulated and measured: every kernel has run

            seconds = time.perf_counter() - start
            total += seconds
            report(variant.label, seconds)
    # the null writer compiles nothing of the caches': the gzip chunks' shuffle kernel, the
    # extents and the gather of frame rows into vertex order (from either state precision) too
    start = time.perf_counter()
    GzipChunkEncoder(3).encode(np.zeros((1, 3), np.float32))
    frame_extent(np.zeros((1, 3), np.float32))
    for precision in (np.float32, np.float64):
        gather_xyz(np.zeros((1, 3), precision), np.zeros(1, np.int64), np.zeros((1, 3), np.float32))
        state = np.zeros((1, 4), precision)
        vertex_rows(state, state, np.zeros(1, np.int64), precision(1.0), np.zeros((1, 3), np.float32), np.zeros((1, 3), np.float32))
    seconds = time.perf_counter() - start
    report("cache frames (HDF5 gzip chunks, extents, vertex order)", seconds)
    return total + seconds
