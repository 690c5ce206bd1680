"""What a bake will cost, checked before it starts.

A typo such as ``solver.frequency = 1e9`` or ``--frames 1:9223372036854775807`` would
otherwise run for hours (or hang a ``--dry-run``) before anyone notices. ``check_workload``
refuses settings that cannot be meant, with the bound in the message:

* hard limits, which nothing overrides: no frame has more than a million iterations and no
  bake more than a hundred million frames (beyond them a bake cannot finish at all);
* soft limits, which ``--force`` (``solver.force``) overrides for the user who does mean it:
  iterations per frame, frame count, total particle-iterations (about 8 CPU hours at
  today's speed), and an estimate of the cache's size against the free disk space.
"""

from __future__ import annotations

import dataclasses
import os
import shutil
from pathlib import Path
from typing import TYPE_CHECKING

from clothtool.errors import SceneError

if TYPE_CHECKING:  # pragma: no cover
    from clothtool.scene.scene import Scene

HARD_ITERATIONS_PER_FRAME = 1_000_000
HARD_FRAMES = 100_000_000
MAX_ITERATIONS_PER_FRAME = 20_000
MAX_FRAMES = 1_000_000
MAX_PARTICLE_ITERATIONS = 2e12
# Compressed HDF5 caches of cloth positions shrink to no less than about this fraction.
COMPRESSED_FRACTION = 0.3


@dataclasses.dataclass(frozen=True)
class Workload:
    frames: int
    iterations_per_frame: int
    particles: int
    particle_iterations: float
    output_bytes: float  # uncompressed estimate of the cache


def iterations_per_frame(frequency: float, fps: float) -> int:
    """The solver's rule: round(frequency / fps), at least one."""
    return max(1, int(frequency / fps + 0.5))


def estimate_workload(scene: "Scene") -> Workload:
    frames = scene.frame_count
    iterations = iterations_per_frame(scene.solver.frequency, scene.fps)
    particles = sum(cloth.fabric.particle_count for cloth in scene.cloths)
    per_point = 12 * (2 if "velocities" in scene.output.attributes else 1)
    return Workload(
        frames=frames,
        iterations_per_frame=iterations,
        particles=particles,
        particle_iterations=float(particles) * iterations * max(frames - 1, 0),
        output_bytes=float(frames) * particles * per_point,
    )


def _free_bytes(output: str | os.PathLike) -> float | None:
    folder = Path(output).parent if str(Path(output).parent) else Path(".")
    try:
        return float(shutil.disk_usage(folder).free)
    except OSError:
        return None


def _size(n: float) -> str:
    for unit in ("B", "KB", "MB", "GB", "TB", "PB"):
        if n < 1000 or unit == "PB":
            return f"{n:.3g} {unit}"
        n /= 1000
    return f"{n:.3g} PB"  # pragma: no cover


def check_workload(scene: "Scene", output: str | os.PathLike | None, force: bool) -> Workload:
    """The bake's workload; raise SceneError (naming the setting and the bound) when it is
    beyond the limits of the module docstring. ``output`` None or "null" writes nothing."""
    work = estimate_workload(scene)
    where = f"{scene.path.name}:"
    rate = f"solver.frequency = {scene.solver.frequency:g} Hz at {scene.fps:g} fps"
    if work.iterations_per_frame > HARD_ITERATIONS_PER_FRAME:
        raise SceneError(
            f"{where} {rate} is {work.iterations_per_frame:,} iterations per frame, beyond the "
            f"{HARD_ITERATIONS_PER_FRAME:,} any bake can run; lower solver.frequency"
        )
    if work.frames > HARD_FRAMES:
        raise SceneError(
            f"{where} frames {scene.start_frame}..{scene.end_frame} are {work.frames:,} frames, beyond the "
            f"{HARD_FRAMES:,} any bake can run; give a shorter range (--frames START:END)"
        )
    if force:
        return work
    hint = "or pass --force to bake it anyway"
    if work.iterations_per_frame > MAX_ITERATIONS_PER_FRAME:
        raise SceneError(
            f"{where} {rate} is {work.iterations_per_frame:,} iterations per frame (limit "
            f"{MAX_ITERATIONS_PER_FRAME:,}); lower solver.frequency, {hint}"
        )
    if work.frames > MAX_FRAMES:
        raise SceneError(
            f"{where} frames {scene.start_frame}..{scene.end_frame} are {work.frames:,} frames (limit "
            f"{MAX_FRAMES:,}); give a shorter range (--frames START:END), {hint}"
        )
    if work.particle_iterations > MAX_PARTICLE_ITERATIONS:
        raise SceneError(
            f"{where} {work.particles:,} particles x {work.iterations_per_frame:,} iterations x "
            f"{work.frames - 1:,} frames are {work.particle_iterations:.3g} particle-iterations (limit "
            f"{MAX_PARTICLE_ITERATIONS:.3g}, about 8 CPU hours); lower solver.frequency or the frame range, {hint}"
        )
    if output is not None and str(output) not in ("null", os.devnull):
        needed = work.output_bytes
        if Path(output).suffix.lower() in (".h5", ".hdf5") and scene.output.compression != "none":
            needed *= COMPRESSED_FRACTION
        free = _free_bytes(output)
        if free is not None and needed > free:
            raise SceneError(
                f"{output}: the cache needs about {_size(needed)} ({work.frames:,} frames of {work.particles:,} "
                f"points) but its disk has {_size(free)} free; free space, choose another directory or a "
                f"shorter range, {hint}"
            )
    return work
