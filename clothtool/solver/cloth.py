"""ClothSolver: one cloth's state, stages and frame loop (NvCloth's position-based solver)."""

from __future__ import annotations

import dataclasses
from typing import Callable

import numpy as np

from clothtool.profile import JIT_STAGE, StageProfiler
from clothtool.settings import SolverConfig
from clothtool.solver.cache_rows import cache_rows, in_vertex_order
from clothtool.solver.environment import Environment
from clothtool.solver.frame import (
    PLANNED_CHUNK,
    FrameHistory,
    FrameInertia,
    FrameMotionAhead,
    FramePath,
    FrameTerms,
    Pose,
    PoseRows,
    extrapolated_path,
)
from clothtool.solver.framefn import FusedFrame, compile_for
from clothtool.solver.iteration import FramePlan, Iteration
from clothtool.solver.kernels.rows import copy_xyz, gather_xyz, vertex_rows, xyz_velocity
from clothtool.solver.logstiffness import damping_scale
from clothtool.solver.model import ClothModel
from clothtool.solver.pipeline import build_stages
from clothtool.solver.sleep import SleepState

FRAME_STAGE = "frame"  # the profile's name for a frame's iterations run in one compiled call


# Particle rows start on a cache line: a float64 row is 32 bytes, and numpy places a big
# array 16 bytes past a page (glibc's block header), where every other row would straddle
# two cache lines (loaded and stored in two pieces: ~8% of the fabric kernel's time).
ROW_ALIGNMENT = 64


def empty_rows(count: int, dtype) -> np.ndarray:
    """An uninitialised (count, 4) C-contiguous array whose data starts on a ROW_ALIGNMENT boundary."""
    dtype = np.dtype(dtype)
    raw = np.empty(count * 4 * dtype.itemsize + ROW_ALIGNMENT, np.uint8)
    start = -raw.ctypes.data % ROW_ALIGNMENT
    return raw[start:start + count * 4 * dtype.itemsize].view(dtype).reshape(count, 4)


@dataclasses.dataclass
class ClothState:
    """Time-varying particle data: xyz and inverse mass in w (NvCloth's layout), f32 (n,4).

    prev.w is each particle's own inverse mass; cur.w may be zeroed for an iteration by a
    motion constraint of radius 0 or scaled by collision, and is restored by integration.
    """

    cur: np.ndarray
    prev: np.ndarray

    @classmethod
    def at_rest(cls, model: ClothModel, dtype=np.float32) -> "ClothState":
        cur = empty_rows(model.particle_count, dtype)
        cur[:, :3] = model.rest_pos
        cur[:, 3] = model.inv_mass
        prev = empty_rows(model.particle_count, dtype)
        prev[:] = cur
        return cls(cur, prev)


class ClothSolver:
    """Simulates one cloth frame by frame; stages run per iteration in the seed's order.

    Args:
        model: the cloth's static data.
        config: solver settings.
        environment: gravity and wind.
        profiler: accumulates time per stage.
        track: time -> Pose of the cloth's frame (local-space simulation), or None.
        teleport_frames: frames at whose start the frame jumps without carrying velocity.
        initial_velocity: (3,) world velocity of the free particles at the start.
        attachment: particles that follow a body (clothtool.solver.attach), or None.
    """

    def __init__(
        self,
        model: ClothModel,
        config: SolverConfig,
        environment: Environment,
        profiler: StageProfiler,
        track: Callable[[float], Pose] | None = None,
        teleport_frames: frozenset[int] = frozenset(),
        initial_velocity=(0.0, 0.0, 0.0),
        attachment=None,
    ):
        self.model = model
        self.attachment = attachment
        self.config = config
        self.environment = environment
        self.profiler = profiler
        # a plain time -> Pose callable is sampled one time at a time
        self.track = track if track is None or isinstance(track, FramePath) else FramePath(track)
        self.frame_scales = np.ones(1)  # this frame's velocity scale per iteration (plan_frame)
        self.frame_ratios = np.ones(1)  # ... and its time-step ratio h / h_prev alone
        self._frame_scales = self.frame_scales
        self._scales_key: tuple | None = None  # (h, h_prev, iterations) of _frame_scales
        self.frame_terms: FrameTerms | None = None  # this frame's motion terms per iteration, with a track
        self.teleport_frames = teleport_frames
        self.initial_velocity = np.asarray(initial_velocity, np.float64)
        self.gravity = np.asarray(environment.gravity, np.float64)
        material = model.material
        self.inertia = FrameInertia(
            material.linear_inertia, material.angular_inertia, material.linear_drag, material.angular_drag
        )
        self.state = ClothState.at_rest(model, np.dtype(config.precision))
        # motion-constraint centres: the rest pose, moved with the body by an attachment
        self.motion_centers = model.rest_pos.astype(self.state.cur.dtype)
        self.history: FrameHistory | None = None
        self.prev_h: float | None = None
        self._teleport_path: Callable[[float], Pose] | None = None  # the frame's path during a teleport frame
        self._ahead: FrameMotionAhead | None = None  # see _terms_ahead
        self.sleep = SleepState()  # see clothtool.solver.sleep
        self.neighbours: list[ClothSolver] = []  # cloths whose particles this one collides with
        self.stages = build_stages(self)
        self._fused = FusedFrame()
        self._callees = None  # the frame function's callee table (clothtool.solver.framecall)

    def set_neighbours(self, neighbours) -> None:
        """The other cloths of the scene (cloth-cloth collision); rebuilds the stage list, so
        call it before the first frame."""
        self.neighbours = [n for n in neighbours if n is not self]
        self.stages = build_stages(self)

    @property
    def asleep(self) -> bool:
        """True while the cloth sleeps: its iterations run no stage."""
        return self.sleep.asleep

    @property
    def stage_names(self) -> list[str]:
        return [stage.name for stage in self.stages]

    # ------------------------------------------------------------------ frame loop
    def plan_frame(self, frame: int, time: float, frame_dt: float, end_time: float | None = None) -> FramePlan:
        """Plan frame ``frame``, simulated from ``time`` to ``end_time`` (default time + frame_dt)."""
        iterations = FramePlan.iterations_for(frame_dt, self.config.frequency)
        h = frame_dt / iterations
        plan = FramePlan(frame, time, frame_dt, iterations, h, self.config.stiffness_frequency * h, end_time)
        self._teleport_path = None
        if self.prev_h is None:
            self._start(plan)
        elif self.history is not None and frame in self.teleport_frames:
            self._teleport(plan)
        self.frame_scales = self._scales(plan)
        self.frame_terms = None
        if self.track is not None:
            ends = plan.iteration_ends()
            terms = None if self._teleport_path else self._terms_ahead(plan, ends)
            if terms is None:
                if self._teleport_path:
                    targets = [self._teleport_path(t) for t in ends]
                else:
                    targets = self.track.poses(ends)
                terms = self.history.advance_many(
                    targets, self.frame_scales, self.gravity, plan.h, self.inertia, self.config.stiffness_frequency,
                    self.state.cur.dtype,
                )
            self.frame_terms = terms
        self.sleep.begin_frame(self, plan)
        for stage in self.stages:
            stage.begin_frame(plan)
        return plan

    def _terms_ahead(self, plan: FramePlan, ends: list[float]) -> FrameTerms | None:
        """The frame's terms from the frame motion computed ahead over all the track's planned
        poses held (a bake's whole path, up to PLANNED_CHUNK iterations: one vectorised pass;
        the same bits as advance_many); None when the frame is not on the planned path
        (advance_many then computes them)."""
        dtype = self.state.cur.dtype
        ahead = self._ahead
        terms = None if ahead is None else ahead.terms(self.history, ends, self.frame_scales, plan.h, dtype)
        if terms is None:
            following, times = self.track.following_rows(ends[0], PLANNED_CHUNK)
            if len(following) > len(ends):
                before, now = self.history.before, self.history.now
                chain = PoseRows(
                    np.concatenate([before.rotation[None], now.rotation[None], following.rotations]),
                    np.concatenate([before.translation[None], now.translation[None], following.translations]),
                    {0: before, 1: now},
                )
                self._ahead = ahead = FrameMotionAhead(
                    chain, times, self.gravity, plan.h, self.inertia, self.config.stiffness_frequency
                )
                terms = ahead.terms(self.history, ends, self.frame_scales, plan.h, dtype)
        return terms

    def _teleport(self, plan: FramePlan) -> None:
        """The track jumps during this frame (between its start and end poses). Sampling the
        track inside the frame would interpolate across the jump and fling the particles, so
        for this frame the cloth follows the track's new path instead, run backwards from the
        frame's end with the motion the track has just after it, and the pose history is
        rebased on that path: the frame keeps moving smoothly and the jump carries no velocity."""
        end = plan.end
        path = extrapolated_path(self.track(end), self.track(end + plan.h), plan.h)
        self.history.rebase(path(plan.time - self.prev_h - end), path(plan.time - end))
        self._teleport_path = lambda t: path(t - end)

    def _start(self, plan: FramePlan) -> None:
        """Initial previous positions so that the first step is exact for constant
        acceleration: x_1 = x_0 + v0 h + g h^2 / 2 (Verlet is then exact for free fall)."""
        h = plan.h
        gravity, velocity = self.gravity, self.initial_velocity
        if self.track is not None:
            # the frame's pose one iteration earlier: the cloth starts moving with its frame
            # (asked first: a FramePath holds its planned poses from the earliest asked for)
            self.history = FrameHistory(self.track(plan.time - h))
            pose = self.history.now = self.track(plan.time)
            gravity = pose.rotation.T @ gravity
            velocity = pose.rotation.T @ velocity
        free = self.state.prev[:, 3] > 0
        offset = (-velocity * h + 0.5 * gravity * h * h).astype(self.state.cur.dtype)
        self.state.prev[free, :3] = self.state.cur[free, :3] + offset
        self.prev_h = h

    def _scales(self, plan: FramePlan) -> np.ndarray:
        """f64 (iterations,) velocity scale of each iteration: damping over h, and the first
        iteration also h / h_prev (the time step's change). The same arrays while h, h_prev
        and the iteration count stay (every frame of a usual bake)."""
        key = (plan.h, self.prev_h, plan.iterations)
        if key != self._scales_key:
            self._scales_key = key
            scale = damping_scale(self.model.material.damping, self.config.stiffness_frequency, plan.h)
            self.frame_ratios = np.ones(plan.iterations)
            self.frame_ratios[0] = plan.h / self.prev_h
            self._frame_scales = scale * self.frame_ratios
        return self._frame_scales

    def iteration(self, plan: FramePlan, index: int) -> Iteration:
        """Iteration ``index`` of the planned frame (its terms were computed by plan_frame);
        the frame history moves to the iteration's poses."""
        self.prev_h = plan.h
        terms = None
        if self.frame_terms is not None:
            terms = self.frame_terms.at(index)
            self.history.before, self.history.now = self.frame_terms.poses[index], self.frame_terms.poses[index + 1]
        return Iteration(index, index / plan.iterations, (index + 1) / plan.iterations, float(self.frame_scales[index]), terms)

    def run_frame(self, plan: FramePlan) -> bool:
        """All iterations of the planned frame in one compiled call (clothtool.solver.framefn):
        the same kernels with the same arguments as ``iterate`` stage by stage, so the same
        bits, without Python between iterations. True: done (integrators that cannot run a
        frame at once return False and the runner calls iteration/iterate instead)."""
        if any(not stage.fused for stage in self.stages):
            return False
        self.prev_h = plan.h
        if self.frame_terms is not None:
            poses = self.frame_terms.poses
            last = len(poses) - 1
            self.history.before, self.history.now = poses[last - 1], poses[last]
        if self.sleep.asleep:
            return True
        function, values, new = self._fused.prepare(self.stages)
        arguments = (plan.iterations, self.state.cur, self.state.prev, *values)
        if new:  # compiled (or loaded from the cache) apart from the frame's time
            with self.profiler.stage(JIT_STAGE):
                self._callees = compile_for(function, arguments)
        with self.profiler.stage(FRAME_STAGE):
            function(*arguments, self._callees)
        for stage in self.stages:
            stage.end_fused_frame()
        return True

    def warm_up(self) -> None:
        """Compile (or load from numba's cache) every kernel this cloth's stages use."""
        for stage in self.stages:
            stage.warm_up()
        none = self.state.cur[:0]
        copy_xyz(none, np.empty((0, 3), none.dtype))
        if self.track is None:  # a cloth in a moving frame (a track) gets its velocities from its poses
            xyz_velocity(none, none, none.dtype.type(1.0), np.empty((0, 3), np.float32))
            order = self.model.fabric.vertex_particle
            if order is not None:  # cache_rows' kernels
                no_rows = np.empty((0, 3), np.float32)
                gather_xyz(none, order[:0], no_rows)
                vertex_rows(none, none, order[:0], none.dtype.type(1.0), no_rows, no_rows)

    def iterate(self, iteration: Iteration) -> None:
        if self.sleep.asleep:
            return
        for stage in self.stages:
            with self.profiler.stage(stage.name):
                stage.run(iteration)

    def step(self, frame: int, time: float, frame_dt: float, end_time: float | None = None) -> FramePlan:
        """Simulate one frame (all its iterations) on its own."""
        plan = self.plan_frame(frame, time, frame_dt, end_time)
        for index in range(plan.iterations):
            self.iterate(self.iteration(plan, index))
        return plan

    # ------------------------------------------------------------------ report
    def frame_stats(self) -> dict:
        """Integrator-specific figures of the last frame (none for this one)."""
        return {}

    def cloth_report(self) -> dict:
        """Integrator-specific facts about the cloth for the bake report (none for this one)."""
        return {}

    # ------------------------------------------------------------------ output
    def world_points(self) -> np.ndarray:
        """(n,3) current positions in world space (scene units), in the state's precision."""
        cur = self.state.cur
        if self.history is None:
            points = np.empty((cur.shape[0], 3), cur.dtype)
            copy_xyz(cur, points)
            return points
        return self._moving_frame_rows(None)[0].astype(cur.dtype)

    def _moving_frame_rows(self, h: float | None) -> tuple[np.ndarray, np.ndarray | None]:
        """A cloth in a moving frame: its float64 (n,3) world points and, given h, its f32
        world velocities over the last iteration (one world transform serves both)."""
        now = self.history.now.to_world(self.state.cur[:, :3])
        if h is None:
            return now, None
        before = self.history.before.to_world(self.state.prev[:, :3])
        return now, ((now - before) / h).astype(np.float32)

    def cache_rows(self, h: float | None) -> tuple[np.ndarray, np.ndarray | None]:
        """See Integrator.cache_rows. Without a moving frame, straight from the state in one
        pass (kernels.rows.vertex_rows: the same bits, no particle-order copies between)."""
        cur = self.state.cur
        if self.history is not None:
            now, velocities = self._moving_frame_rows(h)
            points = in_vertex_order(self.model, now)  # rounded to float32 once, as world_points' were
            return points, None if velocities is None else in_vertex_order(self.model, velocities)
        order = self.model.fabric.vertex_particle
        if order is None:
            return cache_rows(self, h)
        points = np.empty((order.shape[0], 3), np.float32)
        if h is None:
            gather_xyz(cur, order, points)
            return points, None
        velocities = np.empty_like(points)
        vertex_rows(cur, self.state.prev, order, cur.dtype.type(h), points, velocities)
        return points, velocities

    def world_velocities(self, h: float) -> np.ndarray:
        """f32 (n,3) velocities over the last iteration, world space, scene units per second."""
        if self.history is None:
            velocities = np.empty((self.state.cur.shape[0], 3), np.float32)
            xyz_velocity(self.state.cur, self.state.prev, self.state.cur.dtype.type(h), velocities)
            return velocities
        return self._moving_frame_rows(h)[1]
