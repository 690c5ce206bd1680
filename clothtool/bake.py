"""bake(): simulate a scene and stream its frames into a cache. The library entry point.

The frame loop interleaves cloths iteration by iteration (so that cloths can see each
other's current state), measures every cloth after each frame, stops with UnstableError
on NaN/Inf or runaway speed (keeping the frames written so far in a ``.partial`` file), and
writes each frame as soon as it is simulated, so memory does not grow with the frame count.
"""

from __future__ import annotations

import dataclasses
import functools
import time
from pathlib import Path
from typing import Callable

import numpy as np

from clothtool import __version__
from clothtool.errors import ClothtoolError, UnstableError
from clothtool.io.cache import CacheHeader, CacheOptions, ClothTopology, FrameData, open_cache_writer
from clothtool.io.cache_units import PIN_PRIMVAR
from clothtool.profile import StageProfiler
from clothtool.scene.scene import Scene
from clothtool.scene.tracks import quat_to_matrices
from clothtool.sim.integrators import Integrator, check_capabilities, integrator_spec
from clothtool.solver.cache_rows import in_vertex_order
from clothtool.solver.environment import AIR_DENSITY, Environment
from clothtool.solver.frame import FramePath, PoseRows
from clothtool.solver.groupmeter import make_meters
from clothtool.solver.iteration import FramePlan, iteration_offsets
from clothtool.solver.model import build_model
from clothtool.workload import iterations_per_frame

STATS_FIELDS = ("max_speed", "kinetic_energy", "max_strain", "tether_stretch")


@dataclasses.dataclass(frozen=True)
class BakeOptions:
    """percentiles: also compute p99 strain per frame (in the same compiled pass over the
        constraints: about a third more stats time at 128^2);
    penetration: also measure how deep the faces sink into the colliders each frame
        (clothtool.solver.penetration; the command line's bakes do);
    compression / save_every: override the scene's output settings when given;
    progress: called as progress(frames_done, frames_total) after each frame;
    metadata: extra string metadata for the cache header (e.g. a wedge's settings);
    profile_stages: time every solver stage (``--profile``): the position-based solver then
        runs its stages one by one from Python instead of a frame at a time in compiled code
        (the same bits, slower);
    merge_cloths: solve the cloths that can share a solve as one (clothtool.solver.merge; the
        same bits as solving each alone, one compiled call per frame for all of them)."""

    percentiles: bool = False
    penetration: bool = False
    compression: str | None = None
    save_every: int | None = None
    progress: Callable[[int, int], None] | None = None
    metadata: tuple[tuple[str, str], ...] = ()
    profile_stages: bool = False
    merge_cloths: bool = True


@dataclasses.dataclass
class BakeStats:
    """What a bake did; ``to_dict`` is the JSON report (no timestamps, hosts or paths)."""

    scene: str
    output: str
    fps: float
    start_frame: int
    end_frame: int
    frames_simulated: int = 0
    iterations_per_frame: int = 0
    stages: list[str] = dataclasses.field(default_factory=list)
    cloths: dict[str, dict] = dataclasses.field(default_factory=dict)
    per_frame: list[dict] = dataclasses.field(default_factory=list)
    profile: list[dict] = dataclasses.field(default_factory=list)
    wall_s: float = 0.0
    cpu_s: float = 0.0
    jit_s: float = 0.0
    status: str = "ok"
    failure: dict | None = None
    partial_output: str | None = None
    solver: dict = dataclasses.field(default_factory=dict)

    @property
    def simulation_s(self) -> float:
        return max(self.wall_s - self.jit_s, 0.0)

    def overall(self) -> dict:
        """Whole-bake aggregates over the per-frame stats."""
        summary: dict = {}
        for name in self.cloths:
            frames = [f["cloths"][name] for f in self.per_frame if name in f["cloths"]]
            if not frames:
                continue
            strain: dict = {}
            for label in frames[0]["strain"]:
                values = [fr["strain"][label] for fr in frames]
                entry = {"max": max(v["max"] for v in values), "mean": float(np.mean([v["mean"] for v in values]))}
                if "p99" in values[0]:
                    entry["p99"] = max(v["p99"] for v in values)
                strain[label] = entry
            entry = {
                "strain": strain,
                "max_speed": max(f["max_speed"] for f in frames),
                "max_kinetic_energy": max(f["kinetic_energy"] for f in frames),
                "finite": all(f["finite"] for f in frames),
                "asleep_frames": sum(bool(f.get("asleep", False)) for f in frames),
            }
            if "tether_stretch" in frames[0]:
                entry["max_tether_stretch"] = max(f["tether_stretch"] for f in frames)
            if "max_penetration" in frames[0]:  # faces in sphere and capsule colliders, metres
                entry["max_penetration"] = max(f["max_penetration"] for f in frames)
                entry["max_faces_beyond_thickness"] = max(f["faces_beyond_thickness"] for f in frames)
                entry["frames_with_faces_beyond_thickness"] = sum(f["faces_beyond_thickness"] > 0 for f in frames)
            summary[name] = entry
        return summary

    def to_dict(self) -> dict:
        particles = sum(c["particles"] for c in self.cloths.values())
        sim = self.simulation_s
        return {
            "clothtool": __version__,
            "scene": self.scene,
            "output": self.output,
            "status": self.status,
            "failure": self.failure,
            "partial_output": self.partial_output,
            "frames": {
                "start": self.start_frame,
                "end": self.end_frame,
                "simulated": self.frames_simulated,
                "fps": self.fps,
            },
            "solver": self.solver,
            "iterations_per_frame": self.iterations_per_frame,
            "stages": self.stages,
            "cloths": self.cloths,
            "timing": {
                "wall_s": self.wall_s,
                "cpu_s": self.cpu_s,
                "jit_warm_up_s": self.jit_s,
                "simulation_s": sim,
                "frames_per_second": self.frames_simulated / sim if sim > 0 else 0.0,
                "particle_iterations_per_second": (
                    particles * self.iterations_per_frame * self.frames_simulated / sim if sim > 0 else 0.0
                ),
            },
            "profile": self.profile,
            "overall": self.overall(),
            "per_frame": self.per_frame,
        }


def _track_path(track, planned=()) -> FramePath:
    """The cloth frame that follows ``track``, sampled many times at once; ``planned``: the
    times the bake will ask for (``_track_times``), all sampled in one call."""

    def poses(times: np.ndarray) -> PoseRows:
        translations, rotations, _ = track.sample_many(times, scales=False)  # a cloth's frame is rigid
        return PoseRows(quat_to_matrices(rotations), translations)

    return FramePath(lambda time: poses(np.array([time]))[0], poses, planned)


def _track_times(scene: Scene) -> list[float]:
    """Seconds at which the position-based solver asks for a tracked cloth's frame: where its
    first frame starts and one iteration before (its start pose and motion), then the end of
    every iteration of every frame the bake simulates (pre-roll included), as plan_frame
    computes them."""
    frame_dt = 1.0 / scene.fps
    iterations = FramePlan.iterations_for(frame_dt, scene.solver.frequency)
    first = scene.start_frame - scene.preroll + 1
    start = scene.frame_time(first - 1)
    frames = range(first, scene.end_frame + 1)
    # FramePlan.iteration_end for every frame at once (the frame's start plus the offsets, one
    # float64 addition each: its bits); the last iteration of each frame ends on the frame's time
    ends = np.empty((len(frames), iterations))
    ends[:] = np.array([scene.frame_time(frame - 1) for frame in frames])[:, None]
    ends[:, :-1] += np.array(iteration_offsets(frame_dt, iterations))
    ends[:, -1] = [scene.frame_time(frame) for frame in frames]
    return [start - frame_dt / iterations, start] + ends.ravel().tolist()


def rest_time(scene: Scene) -> float:
    """Seconds at which the cloths are at rest: the first pre-roll frame, else the start."""
    return scene.frame_time(scene.start_frame - scene.preroll)


def _attachment(scene: Scene, cloth, model):
    """The binding of ``cloth``'s pinned and max-distance particles to the mesh colliders it
    attaches to (clothtool.solver.attach), or None when it attaches to none."""
    if not cloth.attach or scene.colliders is None:
        return None
    from clothtool.solver.attach import bind_attachment

    pinned = model.inv_mass == 0
    bound = np.flatnonzero(pinned | np.isfinite(model.max_distance))
    if bound.size == 0:
        return None
    points, triangles, mask = scene.colliders.rest_mesh(rest_time(scene), cloth.attach)
    return bind_attachment(model.rest_pos, bound, pinned[bound], points, triangles[mask], cloth.name)


def make_solvers(scene: Scene, profiler: StageProfiler, merge: bool = True) -> list[Integrator]:
    """One solver of the scene's integrator per cloth instance (after checking the
    integrator can do all the scene asks for); with ``merge``, cloths that can share a solve
    share one (clothtool.solver.merge)."""
    solver_class = check_capabilities(scene).load()
    wind = None
    density = AIR_DENSITY
    if scene.wind is not None:
        wind = scene.wind.velocity_at
        density = scene.wind.fluid_density
    colliders = scene.colliders.at if scene.colliders is not None and len(scene.colliders) else None
    environment = Environment(np.asarray(scene.gravity, np.float64), wind, density, colliders)
    solvers = []
    # the times every tracked cloth's frame is asked for, the same for all of them
    track_times = _track_times(scene) if any(cloth.track is not None for cloth in scene.cloths) else []
    for cloth in scene.cloths:
        model = build_model(
            cloth.name, cloth.fabric, cloth.material, cloth.placement, scene.meters_per_unit, scene.up_axis,
            cloth.motion, cloth.backstop,
        )
        track = _track_path(cloth.track, track_times) if cloth.track is not None else None
        teleports = cloth.track.teleport_frames if cloth.track is not None else frozenset()
        extra = {"frame_dt": 1.0 / scene.fps} if scene.solver.integrator == "explicit" else {}
        attachment = _attachment(scene, cloth, model)
        if attachment is not None:
            extra["attachment"] = attachment
        solvers.append(
            solver_class(model, scene.solver, environment, profiler, track, teleports, cloth.initial_velocity, **extra)
        )
    if scene.solver.cloth_collision:  # each cloth collides with the scene's other cloths
        for solver in solvers:
            solver.set_neighbours(solvers)
    if merge and len(solvers) > 1:
        from clothtool.solver.merge import merge_solvers

        solvers = merge_solvers(solvers)
    return solvers


def _does_without(scene: Scene, solver: Integrator) -> dict:
    """What the cloth's fabric carries that its integrator does without, and why."""
    spec = integrator_spec(scene.solver.integrator)
    model = solver.model
    unused = {}
    if "tethers" in spec.does_without and model.has_tethers and model.material.tether_stiffness > 0:
        unused["tethers"] = spec.does_without["tethers"]
    return {"does_without": unused} if unused else {}


def _topology(solver: Integrator, attributes: frozenset[str]) -> ClothTopology:
    """The cloth's render topology and maps for the cache, in the mesh's vertex order (the
    cook may have renumbered the particles for locality: ``Fabric.particle_vertex``)."""
    fabric = solver.model.fabric
    # The painted pin map as DCCs read it (1 pinned, 0 free); the model marks a pin by inverse mass 0.
    primvars = {PIN_PRIMVAR: (solver.model.inv_mass == 0).astype(np.float32)}
    if solver.model.has_motion_constraints:
        primvars["max_distance"] = np.where(
            np.isfinite(solver.model.max_distance), solver.model.max_distance, -1.0
        ).astype(np.float32)
    return ClothTopology(
        name=solver.model.name,
        rest_pos=fabric.in_vertex_order(solver.world_points()),
        face_vertex_counts=fabric.face_vertex_counts,
        face_vertex_indices=fabric.vertex_face_indices(),
        face_vertex_uv=fabric.face_vertex_uv if fabric.face_vertex_uv.shape[0] else None,
        vertex_primvars={name: fabric.in_vertex_order(values) for name, values in primvars.items()},
    )


def _frame_stats_fields(stats: dict) -> dict[str, float]:
    strains = [v["max"] for v in stats["strain"].values()]
    return {
        "max_speed": stats["max_speed"],
        "kinetic_energy": stats["kinetic_energy"],
        "max_strain": max(strains) if strains else 0.0,
        "tether_stretch": stats.get("tether_stretch", 0.0),
    }


def _particles_as_vertices(solver: Integrator, stats: dict) -> None:
    """The particles a frame's stats name, as the mesh's vertex numbers (the cook may have
    renumbered the particles for locality; reports and messages speak of the input mesh)."""
    for key in ("fastest_particle", "nonfinite_particle"):
        if stats.get(key, -1) >= 0:
            stats[key] = solver.model.fabric.vertex_of(stats[key])


def _check_stable(scene: Scene, frame: int, solver: Integrator, stats: dict) -> None:
    name = solver.model.name
    if not stats["finite"]:
        raise UnstableError(
            f"{scene.path.name}: bake went unstable at frame {frame}: cloth '{name}' particle "
            f"{stats['nonfinite_particle']} is NaN or infinite; lower the time step (raise solver.frequency) or check the inputs"
        )
    if stats["max_speed"] > scene.solver.max_speed:
        raise UnstableError(
            f"{scene.path.name}: bake went unstable at frame {frame}: cloth '{name}' particle {stats['fastest_particle']} "
            f"moves at {stats['max_speed']:.3g} m/s (limit solver.max_speed = {scene.solver.max_speed:g}); "
            "raise solver.frequency or damping"
        )


def bake(scene: Scene, output, options: BakeOptions = BakeOptions()) -> BakeStats:
    """Simulate ``scene`` from its start to its end frame into the cache ``output`` (a path
    whose suffix picks the format, "null", or a CacheWriter object such as a
    MemoryCacheWriter).

    The start frame is the rest pose; each later frame is one frame time of simulation.
    Returns the stats; raises UnstableError (with ``.stats``) when the bake goes unstable,
    after keeping the frames written so far under the partial name.
    """
    # numpy's OpenBLAS keeps a thread per core and wakes them for every matrix product, even
    # the (n,3) @ (3,3) of a moving frame's output each frame: 22% of a 256^2 bake's CPU went
    # to spinning BLAS threads. The bake's parallel work is numba's; BLAS stays on this thread.
    with _blas_controller().limit(limits=1, user_api="blas"):
        return _bake(scene, output, options)


@functools.lru_cache(maxsize=1)
def _blas_controller():
    """threadpoolctl's view of the loaded thread pools, found once per process: finding them
    scans every loaded library (1.1 ms, which threadpool_limits paid on every bake). numpy
    loads its BLAS on import, before the first bake."""
    from threadpoolctl import ThreadpoolController

    return ThreadpoolController()


def _bake(scene: Scene, output, options: BakeOptions) -> BakeStats:
    wall0, cpu0 = time.perf_counter(), time.process_time()
    profiler = StageProfiler()
    solvers = make_solvers(scene, profiler, options.merge_cloths)
    meters = make_meters(solvers)  # a merged group's cloths are measured together
    stats = BakeStats(
        scene=scene.name,
        output=Path(str(getattr(output, "path", output))).name,
        fps=scene.fps,
        start_frame=scene.start_frame,
        end_frame=scene.end_frame,
        solver=dataclasses.asdict(scene.solver),
        cloths={
            s.model.name: {
                "particles": s.model.particle_count,
                "constraints": int(s.model.constraint_indices.shape[0]),
                "source": c.source,
                "stages": s.stage_names,
                **s.cloth_report(),
                **_does_without(scene, s),
            }
            for s, c in zip(solvers, scene.cloths)
        },
    )
    stages_seen = []
    for solver in solvers:
        stages_seen += [name for name in solver.stage_names if name not in stages_seen]
    stats.stages = stages_seen

    kinds = {c.kind for c in scene.colliders.colliders} if options.penetration and scene.colliders is not None else set()
    mesh_penetration, shape_penetration = "mesh" in kinds, bool(kinds & {"sphere", "capsule"})
    with profiler.stage("jit warm-up"):
        for solver, meter in zip(solvers, meters):
            solver.warm_up()
            meter.warm_up(options.percentiles, mesh_penetration, shape_penetration)
    if scene.colliders is not None:  # the colliders at every frame's time, sampled at once
        scene.colliders.prefetch([scene.frame_time(f) for f in range(scene.start_frame - scene.preroll, scene.end_frame + 1)])
    # Cloths that do not collide with each other need not interleave: each runs its frame
    # in one compiled call, unless every stage is to be timed (the same bits either way).
    whole_frames = not options.profile_stages and not (scene.solver.cloth_collision and len(solvers) > 1)
    preroll(scene, solvers, whole_frames)

    attributes = scene.output.attributes
    cache_options = CacheOptions(
        compression=options.compression or scene.output.compression,
        save_every=options.save_every or scene.output.save_every,
    )
    header = CacheHeader(
        fps=scene.fps,
        start_frame=scene.start_frame,
        end_frame=scene.end_frame,
        meters_per_unit=scene.meters_per_unit,
        up_axis=scene.up_axis,
        cloths=tuple(_topology(solver, attributes) for solver in solvers),
        colliders=scene.colliders.infos() if _writes_colliders(scene) else (),
        attributes=frozenset(attributes),
        stats_fields=STATS_FIELDS if "stats" in attributes else (),
        metadata={**dict(options.metadata), "scene": scene.name, "generator": f"clothtool {__version__}"},
    )
    total = scene.frame_count
    frame_dt = 1.0 / scene.fps
    writer = output if hasattr(output, "write_frame") else open_cache_writer(output, cache_options)
    frame = scene.start_frame
    try:
        with writer:
            writer.write_header(header)
            discards = getattr(writer, "discards_frames", False)  # see CacheWriter
            with profiler.stage("write"):
                if discards:
                    writer.skip_frame(scene.start_frame)
                else:
                    writer.write_frame(_with_colliders(scene, _initial_frame(scene, solvers, attributes)))
            if options.progress:
                options.progress(1, total)
            for done, frame in enumerate(range(scene.start_frame + 1, scene.end_frame + 1), start=2):
                with profiler.stage("plan"):  # frame terms, collider and attachment poses (Python)
                    plans = [s.plan_frame(frame, scene.frame_time(frame - 1), frame_dt, scene.frame_time(frame)) for s in solvers]
                stats.iterations_per_frame = max(p.iterations for p in plans)
                simulate_frame(solvers, plans, whole_frames)
                with profiler.stage("stats"):
                    per_cloth = {}
                    for solver, meter, plan in zip(solvers, meters, plans):
                        cloth_stats = meter.measure(plan.h, options.percentiles, plan.end if options.penetration else None)
                        cloth_stats["asleep"] = solver.asleep  # asleep at the frame's end
                        _particles_as_vertices(solver, cloth_stats)
                        cloth_stats.update(solver.frame_stats())  # e.g. the implicit solver's CG figures
                        per_cloth[solver.model.name] = cloth_stats
                    stats.per_frame.append({"frame": frame, "cloths": per_cloth})
                    stats.frames_simulated += 1
                    for solver in solvers:
                        _check_stable(scene, frame, solver, per_cloth[solver.model.name])
                with profiler.stage("write"):
                    if discards:
                        writer.skip_frame(frame)
                    else:
                        writer.write_frame(_with_colliders(scene, _frame_data(frame, solvers, plans, per_cloth, attributes)))
                if options.progress:
                    options.progress(done, total)
            writer.commit()
    except (ClothtoolError, KeyboardInterrupt) as exc:
        # What the command line reports: the frame the bake was at and the partial file kept.
        written = getattr(writer, "frames_written", None)
        exc.frame = frame if written is None else min(scene.start_frame + written, scene.end_frame)
        exc.kept = getattr(writer, "kept", None)
        if not isinstance(exc, UnstableError):
            raise
        stats.status = "unstable"
        stats.failure = {"frame": stats.per_frame[-1]["frame"] if stats.per_frame else scene.start_frame, "message": str(exc)}
        stats.partial_output = exc.kept[0].name if exc.kept else None
        _finish(stats, profiler, wall0, cpu0)
        exc.stats = stats
        raise
    _finish(stats, profiler, wall0, cpu0)
    return stats


def simulate_frame(solvers: list[Integrator], plans: list, whole_frames: bool) -> None:
    """Run the planned frame of every cloth: with ``whole_frames`` each cloth's iterations in
    one call where its integrator can (``run_frame``), the rest interleaved iteration by
    iteration (so that cloths see each other's current state)."""
    if whole_frames:
        pending = [(s, p) for s, p in zip(solvers, plans) if not s.run_frame(p)]
        if not pending:
            return
    else:
        pending = list(zip(solvers, plans))
    for index in range(max((p.iterations for _, p in pending), default=0)):
        for solver, plan in pending:
            if index < plan.iterations:
                solver.iterate(solver.iteration(plan, index))


def preroll(scene: Scene, solvers: list[Integrator], whole_frames: bool = False) -> None:
    """Simulate ``scene.preroll`` frames before the start frame (not written): the bodies
    blend from their rest pose to the first frame's, and the cloths settle on them."""
    frame_dt = 1.0 / scene.fps
    for frame in range(scene.start_frame - scene.preroll + 1, scene.start_frame + 1):
        plans = [s.plan_frame(frame, scene.frame_time(frame - 1), frame_dt, scene.frame_time(frame)) for s in solvers]
        simulate_frame(solvers, plans, whole_frames)


def _finish(stats: BakeStats, profiler: StageProfiler, wall0: float, cpu0: float) -> None:
    stats.wall_s = time.perf_counter() - wall0
    stats.cpu_s = time.process_time() - cpu0
    stats.jit_s = profiler.seconds.get("jit warm-up", 0.0)
    stats.profile = profiler.table(stats.frames_simulated)


def _writes_colliders(scene: Scene) -> bool:
    return "colliders" in scene.output.attributes and scene.colliders is not None and len(scene.colliders) > 0


def _with_colliders(scene: Scene, frame: FrameData) -> FrameData:
    """Add the colliders' world transforms (and deformed points) at the frame's time."""
    if not _writes_colliders(scene):
        return frame
    time = scene.frame_time(frame.frame)
    return dataclasses.replace(
        frame, collider_xforms=scene.colliders.xforms(time), collider_points=scene.colliders.deformed_points(time)
    )


def _initial_frame(scene: Scene, solvers: list[Integrator], attributes) -> FrameData:
    velocities = None
    if "velocities" in attributes:
        velocities = []
        for solver, cloth in zip(solvers, scene.cloths):
            v = np.zeros((solver.model.particle_count, 3), np.float32)
            v[solver.model.inv_mass > 0] = cloth.initial_velocity
            velocities.append(in_vertex_order(solver.model, v))
        velocities = tuple(velocities)
    stats = None
    if "stats" in attributes:
        stats = tuple({field: 0.0 for field in STATS_FIELDS} for _ in solvers)
    return FrameData(scene.start_frame, tuple(solver.cache_rows(None)[0] for solver in solvers), velocities, stats)


def _frame_data(frame, solvers, plans, per_cloth, attributes) -> FrameData:
    with_velocities = "velocities" in attributes
    rows = [s.cache_rows(p.h if with_velocities else None) for s, p in zip(solvers, plans)]
    stats = None
    if "stats" in attributes:
        stats = tuple(_frame_stats_fields(per_cloth[s.model.name]) for s in solvers)
    return FrameData(
        frame, tuple(points for points, _ in rows), tuple(v for _, v in rows) if with_velocities else None, stats
    )


def plan(scene: Scene, calibration_frames: int = 2, calibration_seconds: float = 2.0) -> dict:
    """The stage plan of ``scene`` without baking it: per cloth the stages that would run and
    the iterations per frame, and an estimated cost from simulating a couple of frames (or
    fewer iterations, when those take longer than ``calibration_seconds``)."""
    profiler = StageProfiler()
    solvers = make_solvers(scene, profiler)
    for solver in solvers:
        solver.warm_up()
    frames = min(calibration_frames, max(scene.frame_count - 1, 0))
    frame_dt = 1.0 / scene.fps
    iterations = iterations_per_frame(scene.solver.frequency, scene.fps)
    simulated = 0  # iterations, summed over the calibration frames
    deadline = time.perf_counter() + calibration_seconds
    for frame in range(scene.start_frame + 1, scene.start_frame + 1 + frames):
        plans = [s.plan_frame(frame, scene.frame_time(frame - 1), frame_dt, scene.frame_time(frame)) for s in solvers]
        iterations = max(p.iterations for p in plans)
        for index in range(iterations):
            for solver, frame_plan in zip(solvers, plans):
                if index < frame_plan.iterations:
                    solver.iterate(solver.iteration(frame_plan, index))
            simulated += 1
            if time.perf_counter() > deadline:
                break
        else:
            continue
        break
    per_frame = {name: seconds * iterations / max(simulated, 1) for name, seconds in profiler.seconds.items()}
    estimate = sum(per_frame.values()) * (scene.frame_count - 1)
    return {
        "scene": scene.name,
        "frames": {"start": scene.start_frame, "end": scene.end_frame, "fps": scene.fps},
        "iterations_per_frame": iterations,
        "solver": dataclasses.asdict(scene.solver),
        "cloths": {
            s.model.name: {"particles": s.model.particle_count, "constraints": int(s.model.constraint_indices.shape[0]),
                           "stages": s.stage_names}
            for s in solvers
        },
        "calibration_frames": frames,
        "calibration_iterations": simulated,
        "stage_ms_per_frame": {name: 1000.0 * seconds for name, seconds in per_frame.items()},
        "estimated_bake_s": estimate,
    }


def format_plan(data: dict) -> str:
    lines = [
        f"plan {data['scene']}: frames {data['frames']['start']}..{data['frames']['end']} at {data['frames']['fps']:g} fps, "
        f"{data['iterations_per_frame']} iterations per frame ({data['solver']['stiffness_mode']} stiffness, "
        f"{data['solver']['frequency']:g} Hz)"
    ]
    for name, cloth in data["cloths"].items():
        lines.append(f"  {name}: {cloth['particles']} particles, {cloth['constraints']} constraints; stages {', '.join(cloth['stages'])}")
    lines.append(f"  calibration over {data['calibration_iterations']} iterations, ms per frame:")
    for stage, ms in data["stage_ms_per_frame"].items():
        lines.append(f"    {stage:<14} {ms:9.3f}")
    lines.append(f"  estimated bake time {data['estimated_bake_s']:.2f} s (JIT compile and cache writing excluded)")
    return "\n".join(lines)
