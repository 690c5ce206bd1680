"""ExplicitClothSolver: the classic mass-spring cloth (the talk), symplectic Euler with substeps.

Points with mass, position, velocity and force; springs along the fabric's constraints
(stretch, shear and bend phases) with stiffness from the material's moduli and damping along
the spring (``springs``); gravity; the air's drag and lift per triangle (the law of
``clothtool.solver.kernels.air``, as in the other integrators); collisions with the scene's colliders after the position update. Each substep of
length h = frame_dt / round(frame_dt * solver.frequency):

    forces     f = sum of spring forces (+ damping)
    wind       f += per-triangle drag and lift (when the material has a drag or lift coefficient)
    integrate  v += h (g + f / m) ;  x += h v              (pinned particles never move)
    collide    project out of the colliders, inelastic normal velocity, Coulomb friction

The solver drives like ``clothtool.solver.cloth.ClothSolver`` (same constructor, frame plan,
iterations and output methods), so the bake can run either. It simulates in world space and
refuses a tracked (local-space) cloth. It refuses, too, a substep longer than the stability
limit (``stability``) unless ``config.force`` is set. Not modelled (its capabilities in
``clothtool.sim.integrators``; a scene that asks for them is refused): motion and separation
constraints, self- and cloth-cloth collision, sleeping; tethers go unused. Collision is
always continuous (solver.continuous_collision is accepted and changes nothing).
"""

from __future__ import annotations

import math

import numpy as np

from clothtool.errors import SceneError, UnstableError
from clothtool.integrators.explicit.kernels.explicit_collide import collide_colliders
from clothtool.integrators.explicit.kernels.explicit_integrate import symplectic_euler
from clothtool.integrators.explicit.kernels.explicit_springs import spring_forces, spring_forces_sets
from clothtool.integrators.explicit.kernels.explicit_wind import wind_forces
from clothtool.integrators.explicit.springs import air_density, spring_damping, spring_stiffness
from clothtool.integrators.explicit.stability import stability_report
from clothtool.solver.air import corner_shares
from clothtool.solver.cache_rows import cache_rows
from clothtool.solver.cloth import ClothState
from clothtool.solver.collide import CollideStage
from clothtool.solver.iteration import FramePlan, Iteration
from clothtool.solver.sleep import SleepState


def substeps(frame_dt: float, frequency: float) -> int:
    """Substeps per frame: frame_dt * frequency rounded (half up, as ClothSolver), at least 1."""
    return max(1, int(frame_dt * frequency + 0.5))


class ExplicitClothSolver:
    """Simulates one cloth frame by frame with explicit mass-spring dynamics.

    Args:
        model: the cloth's static data (world space: the cloth follows no track).
        config: solver settings (``frequency`` sets the substep; ``force`` skips the
            stability check; ``precision`` the state's dtype).
        environment: gravity, wind, fluid density, colliders.
        profiler: accumulates time per stage.
        track: must be None (raises SceneError otherwise).
        teleport_frames: accepted for interface compatibility (only meaningful with a track).
        initial_velocity: (3,) world velocity of the free particles at the start.
        frame_dt: when given, the stability check runs here already (else in plan_frame).
    """

    # world space: no moving frame, so the collider stage poses with identity frames
    frame_terms = None

    def __init__(
        self,
        model,
        config,
        environment,
        profiler,
        track=None,
        teleport_frames: frozenset[int] = frozenset(),
        initial_velocity=(0.0, 0.0, 0.0),
        frame_dt: float | None = None,
    ):
        if track is not None:
            raise SceneError(
                f"cloth '{model.name}': the explicit integrator simulates in world space; "
                "remove the cloth's track or use solver.integrator = \"pbd\""
            )
        self.model = model
        self.config = config
        self.environment = environment
        self.profiler = profiler
        self.track = None
        self.history = None
        self.teleport_frames = teleport_frames
        self.initial_velocity = np.asarray(initial_velocity, np.float64)
        self.gravity = np.asarray(environment.gravity, np.float64)
        self.gravity_state = self.gravity.astype(config.precision)
        self.neighbours: list = []
        self.sleep = SleepState()  # never falls asleep; read by neighbours' stages
        dtype = np.dtype(config.precision)
        self.dtype = dtype
        self.state = ClothState.at_rest(model, dtype)
        n = model.particle_count
        self.velocity = np.zeros((n, 3), dtype)
        self.force = np.zeros((n, 3), dtype)

        stiffness = spring_stiffness(model)
        self.spring_stiffness = stiffness.astype(dtype)
        self.spring_damping = spring_damping(model, stiffness).astype(dtype)
        self.spring_rest = model.constraint_rest_length.astype(dtype)
        self.set_offsets = np.ascontiguousarray(model.set_offsets, np.int32)
        set_sizes = np.diff(model.set_offsets)
        # thread start-up costs more than it saves on small sets (as for the fabric stage)
        self.parallel = bool(set_sizes.size and set_sizes.max() >= config.parallel_threshold)

        material = model.material
        density = float(getattr(environment, "fluid_density", 1.0))
        self.has_wind = (material.drag_coefficient > 0 or material.lift_coefficient > 0) and density > 0 and model.triangles.shape[0] > 0
        self.air_density = dtype.type(air_density(model, density) if self.has_wind else 0.0)
        self.air_share = corner_shares(model).astype(dtype)
        self.drag = dtype.type(material.drag_coefficient)
        self.lift = dtype.type(material.lift_coefficient)
        # the colliders' motion over a frame, posed per substep: the position-based stage's
        self.colliders = None
        if getattr(environment, "colliders", None) is not None:
            self.colliders = CollideStage(self, faces=False, continuous=True)

        self.stage_names = ["forces"] + (["wind"] if self.has_wind else []) + ["integrate"]
        self.stage_names += ["collide"] if self.colliders is not None else []
        self.stability = stability_report(model, environment if self.has_wind else None)
        self._plan: FramePlan | None = None
        self._started = False
        if frame_dt is not None:
            self.check_step(frame_dt / substeps(frame_dt, config.frequency), frame_dt)

    # ------------------------------------------------------------------ interface glue
    @property
    def asleep(self) -> bool:
        return False

    def set_neighbours(self, neighbours) -> None:
        """Recorded for the other cloths' benefit; the explicit integrator does not collide
        with other cloths."""
        self.neighbours = [n for n in neighbours if n is not self]

    # ------------------------------------------------------------------ stability
    def check_step(self, h: float, frame_dt: float | None = None) -> None:
        """Raise UnstableError when the substep h exceeds the stability limit (times the
        accepted factor), unless ``config.force`` is set."""
        h_max = self.stability["h_max_s"]
        if h <= self.stability["factor"] * h_max or self.config.force:
            return
        frequency = 1.0 / h_max
        if frame_dt is not None:  # the lowest frequency whose rounded substep count is enough
            frequency = math.ceil(frame_dt / h_max) / frame_dt
        raise UnstableError(
            f"cloth '{self.model.name}': explicit integration is unstable at h = {h:.3g} s: the stiffest spring "
            f"needs h <= {h_max:.3g} s (frequency >= {frequency:.6g} Hz); raise solver.frequency or pass --force"
        )

    # ------------------------------------------------------------------ frame loop
    def plan_frame(self, frame: int, time: float, frame_dt: float, end_time: float | None = None) -> FramePlan:
        """Plan frame ``frame``, simulated from ``time`` to ``end_time`` (default time + frame_dt)."""
        iterations = substeps(frame_dt, self.config.frequency)
        h = frame_dt / iterations
        self.check_step(h, frame_dt)
        plan = FramePlan(frame, time, frame_dt, iterations, h, self.config.stiffness_frequency * h, end_time)
        if not self._started:
            self._start(h)
        if self.colliders is not None:
            self.colliders.begin_frame(plan)
        self._plan = plan
        return plan

    def _start(self, h: float) -> None:
        """Free particles start with the initial velocity; prev = cur - v h."""
        free = self.model.inv_mass > 0
        self.velocity[free] = self.initial_velocity.astype(self.dtype)
        state = self.state
        state.prev[free, :3] = state.cur[free, :3] - self.velocity[free] * self.dtype.type(h)
        self._started = True

    def iteration(self, plan: FramePlan, index: int) -> Iteration:
        self._plan = plan
        return Iteration(index, index / plan.iterations, (index + 1) / plan.iterations, 1.0, None)

    def warm_up(self) -> None:
        """Compile (or load from numba's cache) every kernel, on zero-length views."""
        state, model, dtype = self.state, self.model, self.dtype
        cur, prev, velocity, force = state.cur[:0], state.prev[:0], self.velocity[:0], self.force[:0]
        zero = dtype.type(0.0)
        springs = (model.constraint_indices[:0], self.spring_rest[:0], self.spring_stiffness[:0], self.spring_damping[:0])
        if self.parallel:
            spring_forces_sets(*springs, self.set_offsets[:1], cur, velocity, force)
        else:
            spring_forces(*springs, cur, velocity, force)
        if self.has_wind:
            wind_forces(model.triangles[:0], self.air_share, np.zeros(3, dtype), zero, zero, zero, cur, velocity, force)
        symplectic_euler(np.zeros(3, dtype), zero, force, cur, prev, velocity)
        if self.colliders is not None:
            self.colliders.warm_up_motion()
            shapes, mesh = self.colliders.groups(empty=True)
            collide_colliders(shapes, mesh, self.colliders.frame, zero, cur, prev, velocity)

    def run_frame(self, plan: FramePlan) -> bool:
        """Frames run iteration by iteration (the runner calls iteration/iterate)."""
        return False

    def iterate(self, iteration: Iteration) -> None:
        """One symplectic Euler substep of length plan.h."""
        plan = self._plan
        h = self.dtype.type(plan.h)
        with self.profiler.stage("forces"):
            self._forces()
        if self.has_wind:
            with self.profiler.stage("wind"):
                self._wind(plan.time + iteration.index * plan.h)
        with self.profiler.stage("integrate"):
            symplectic_euler(self.gravity_state, h, self.force, self.state.cur, self.state.prev, self.velocity)
        if self.colliders is not None:
            with self.profiler.stage("collide"):
                self._collide(iteration, h)

    def step(self, frame: int, time: float, frame_dt: float, end_time: float | None = None) -> FramePlan:
        """Simulate one frame (all its substeps) on its own."""
        plan = self.plan_frame(frame, time, frame_dt, end_time)
        for index in range(plan.iterations):
            self.iterate(self.iteration(plan, index))
        return plan

    # ------------------------------------------------------------------ stages
    def _forces(self) -> None:
        self.force.fill(0.0)
        springs = (self.model.constraint_indices, self.spring_rest, self.spring_stiffness, self.spring_damping)
        if self.parallel:
            spring_forces_sets(*springs, self.set_offsets, self.state.cur, self.velocity, self.force)
        else:
            spring_forces(*springs, self.state.cur, self.velocity, self.force)

    def _wind(self, time: float) -> None:
        air = self.environment.wind_at(time).astype(self.dtype)
        wind_forces(self.model.triangles, self.air_share, air, self.drag, self.lift, self.air_density, self.state.cur, self.velocity, self.force)

    def _collide(self, iteration: Iteration, h) -> None:
        stage = self.colliders
        stage.pose(iteration)
        shapes, mesh = stage.groups()
        collide_colliders(shapes, mesh, stage.frame, h, self.state.cur, self.state.prev, self.velocity)

    # ------------------------------------------------------------------ output
    def frame_stats(self) -> dict:
        """Integrator-specific figures of the last frame (none for this one)."""
        return {}

    def cloth_report(self) -> dict:
        """The stability analysis of the substep, for the bake report."""
        return {"stability": self.stability}

    def world_points(self) -> np.ndarray:
        """(n,3) current positions in world space (scene units), in the state's precision."""
        return np.ascontiguousarray(self.state.cur[:, :3])

    def cache_rows(self, h: float | None) -> tuple[np.ndarray, np.ndarray | None]:
        """See Integrator.cache_rows."""
        return cache_rows(self, h)

    def world_velocities(self, h: float) -> np.ndarray:
        """f32 (n,3) world velocities in scene units per second: the integrator's own velocity
        (equal to (cur - prev) / h up to rounding)."""
        return self.velocity.astype(np.float32)
