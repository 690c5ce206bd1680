"""ImplicitClothSolver: Baraff & Witkin's implicit integrator behind ClothSolver's interface.

One step of length h (the slides 21-22, linearised backward Euler):

    (M - h df/dv - h^2 df/dx) dv = h (f0 + h df/dx v0)
    v1 = v0 + dv,  x1 = x0 + h v1

with f0 the stretch, shear, bend, damping, drag and gravity forces at (x0, v0) and the
Jacobians of ``kernels.implicit_energies`` (stretch's second-derivative term only while stretched, shear's
and bend's dropped: the matrix stays symmetric positive definite). It is the slides' system
multiplied by M, so the conjugate gradient applies; fixed particles are filtered out.

Stages per step: ``forces`` (forces and Jacobian blocks), ``assemble`` (mass, right-hand
side, preconditioner), ``cg-solve``; then, when the scene needs them, ``collide`` (Bridson's
repulsion, friction and inelastic impulses), ``strain-limit``, ``motion`` (max distance) and
``collide`` again (the final robust pass, so that no particle ends inside a collider); and
``integrate`` (positions, velocities and the state).

Units and material parameters:

* stretch and shear moduli (N/m) enter unchanged in scene units: for x in scene units and
  masses in kg the force in kg scene-units/s^2 derives from E_J / L^2 (L = metres per unit),
  and the membrane energy Y a_m eps^2 / 2 over L^2 is Y a eps^2 / 2 with a in scene units;
* the bend modulus D (N m = J) becomes D / L^2;
* compression: an axis shorter than at rest resists with ``config.compression_ratio``
  (default 0.1) times the stretch modulus. Woven cloth buckles rather than compresses
  (the slides' "buckling effect"); with full compression stiffness a coarse mesh cannot
  drape (over a sphere it tents and never settles);
* damping is stiffness-proportional with the time constant damping_time = material.damping /
  config.stiffness_frequency (NvCloth gives damping per stiffness-frequency step): for cotton
  (0.1 at 100 Hz) 1 ms, which damps stretch vibrations critically and leaves the slow
  swinging of the cloth alone; rigid motion is not damped;
* air drag and lift (only with a drag or lift coefficient), as the position-based solver's
  wind stage (the law of ``clothtool.solver.kernels.air``): 1/2 rho C_d A |cos| |u| u per
  triangle plus lift, u its velocity relative to the wind, a third on each corner, with
  rho = environment.fluid_density (kg/m^3) and the material's C_d and C_l; the drag enters
  the system matrix, the lift (at right angles to the motion) stays explicit;
* collisions use the material's thickness and stretch modulus (the repulsion spring) and the
  colliders' margins and friction.

Safety net: ``strain`` limiting to ``config.strain_limit`` (default 0.1, 0 = off) after the
solve, because one linear step per frame cannot turn an edge far (see ``kernels.implicit_strain``).

Not done by this integrator (its capabilities in ``clothtool.sim.integrators``; a scene that
asks for them is refused): local-space simulation (a cloth that follows a track), separation
(backstop) spheres, self- and cloth-cloth collision, and sleeping (collision is always
continuous: solver.continuous_collision is accepted and changes nothing); tethers go
unused (the stiff stretch and the strain limit hold the cloth). Motion constraints are a
projection after the solve: a particle outside its sphere is put back on it and loses its
outward velocity; a radius of 0 fixes the particle at its rest position.

State: positions and velocities are float64 inside; ``state.cur`` holds the positions and the
inverse mass in w and ``state.prev`` = cur - v h, in ``config.precision``, after every step.
"""

from __future__ import annotations

import contextlib
import dataclasses

import numba
import numpy as np

from clothtool.errors import SceneError
from clothtool.integrators.implicit.kernels.implicit_cg import CHUNKS, block_jacobi, filtered_pcg
from clothtool.integrators.implicit.kernels.implicit_collision import NO_CONTACT, collide_particles, project_particles
from clothtool.integrators.implicit.kernels.implicit_energies import drag_terms, hinge_terms, triangle_terms
from clothtool.integrators.implicit.kernels.implicit_strain import limit_strain
from clothtool.integrators.implicit.pattern import build_pattern, color_elements, triangle_edges
from clothtool.integrators.implicit.rest import build_rest_shape, triangle_corner_uvs
from clothtool.profile import StageProfiler
from clothtool.settings import SolverConfig
from clothtool.solver.air import corner_shares
from clothtool.solver.cache_rows import cache_rows
from clothtool.solver.collide import CollideStage
from clothtool.solver.environment import Environment
from clothtool.solver.iteration import FramePlan, Iteration
from clothtool.solver.model import ClothModel

COLLISION_PASSES = 4  # rounds of inelastic impulses before the final projection
STRAIN_SWEEPS = 8  # Gauss-Seidel sweeps of strain limiting


@dataclasses.dataclass
class ImplicitState:
    """The particle state in ClothState's layout (the meters and writers read it): cur (n,4)
    positions and inverse mass in w, prev (n,4) = cur - v h, so (cur - prev)/h is the
    velocity."""

    cur: np.ndarray
    prev: np.ndarray


@dataclasses.dataclass(frozen=True)
class ImplicitParameters:
    """The material and settings in the units of the solve (see the module docstring)."""

    stretch: float  # N/m
    compression: float  # factor on the stretch modulus for an axis shorter than at rest
    shear: float  # N/m
    bend: float  # D / L^2
    damping_time: float  # s
    drag: float  # C_d
    lift: float  # C_l
    air_density: float  # rho L^3 / 12 (the air law's corner force in kg scene-units/s^2, scene units)
    thickness: float  # scene units
    repulsion: float  # N/m
    strain_limit: float  # largest edge stretch kept after a step (0 = no limit)
    cg_tolerance: float  # relative residual
    cg_max_iterations: int

    @property
    def has_air(self) -> bool:
        """Whether the air law has anything to do (a drag or lift coefficient and air)."""
        return (self.drag > 0 or self.lift > 0) and self.air_density > 0

    @classmethod
    def of(cls, model: ClothModel, config: SolverConfig, environment: Environment) -> "ImplicitParameters":
        material = model.material
        to_m = model.units_to_meters
        return cls(
            stretch=float(material.stretch_modulus),
            compression=float(getattr(config, "compression_ratio", 0.1)),
            shear=float(material.shear_modulus),
            bend=float(material.bend_modulus) / (to_m * to_m),
            damping_time=float(material.damping) / float(config.stiffness_frequency),
            drag=float(material.drag_coefficient),
            lift=float(material.lift_coefficient),
            air_density=float(environment.fluid_density) * to_m**3 / 12.0,
            thickness=float(material.thickness) / to_m,
            repulsion=float(material.stretch_modulus),
            strain_limit=float(getattr(config, "strain_limit", 0.1)),
            cg_tolerance=float(getattr(config, "cg_tolerance", 1e-6)),
            cg_max_iterations=int(getattr(config, "cg_max_iterations", 200)),
        )


class ImplicitClothSolver:
    """Simulates one cloth frame by frame with Baraff & Witkin's implicit integrator.

    Args: as ``clothtool.solver.cloth.ClothSolver``; ``track`` must be None (world space
    only) and ``teleport_frames`` is unused. Optional settings read from ``config`` with
    defaults: ``cg_tolerance`` (1e-6, relative residual), ``cg_max_iterations`` (200),
    ``compression_ratio`` (0.1), ``strain_limit`` (0.1), ``parallel_threshold``.
    """

    # world space: no moving frame, so the collider stage poses with identity frames
    frame_terms = None

    def __init__(
        self,
        model: ClothModel,
        config: SolverConfig,
        environment: Environment,
        profiler: StageProfiler,
        track=None,
        teleport_frames: frozenset[int] = frozenset(),
        initial_velocity=(0.0, 0.0, 0.0),
    ):
        if track is not None:
            raise SceneError(
                f"cloth '{model.name}': the implicit integrator simulates in world space only and cannot follow "
                "a track; remove the cloth's track or use solver.integrator = \"pbd\""
            )
        self.model = model
        self.config = config
        self.environment = environment
        self.profiler = profiler
        self.teleport_frames = teleport_frames
        self.params = ImplicitParameters.of(model, config, environment)
        self.gravity = np.asarray(environment.gravity, np.float64)
        self.colliders = getattr(environment, "colliders", None)
        self.history = None  # world space: the colliders are posed without a moving frame
        self.neighbours: list = []
        n = model.particle_count
        # below the threshold a step runs on one thread: a parallel region costs a thread
        # wake-up per launch (microseconds, milliseconds on a busy machine) and a CG
        # iteration launches four
        self.single_thread = n < config.parallel_threshold

        # static data
        self.rest = build_rest_shape(model.rest_pos, model.triangles, triangle_corner_uvs(model.fabric))
        self.air_share = corner_shares(model).astype(np.float64)
        self.pattern = build_pattern(n, self.rest.triangles, self.rest.hinges)
        self.triangle_colors = color_elements(self.rest.triangles, n)
        self.hinge_colors = color_elements(self.rest.hinges, n)
        self.edges = triangle_edges(self.rest.triangles, n)
        rest64 = model.rest_pos.astype(np.float64)
        self.edge_rest_length = np.linalg.norm(rest64[self.edges[:, 1]] - rest64[self.edges[:, 0]], axis=1)
        self.edge_colors = color_elements(self.edges, n)
        self.mass = np.ascontiguousarray(model.mass, np.float64)
        self.rest_pos = rest64
        radius = model.max_distance.astype(np.float64) * model.motion.scale + model.motion.bias
        self.motion_radius = np.where(np.isfinite(model.max_distance), np.maximum(radius, 0.0), np.inf)
        self.has_motion = bool(np.isfinite(self.motion_radius).any())
        self.free = ((model.inv_mass > 0) & (self.motion_radius > 0)).astype(np.uint8)
        self.inv_mass = np.where(self.free != 0, 1.0 / self.mass, 0.0)

        # state
        self.x = rest64.copy()
        self.v = np.zeros((n, 3))
        self.v[self.free != 0] = np.asarray(initial_velocity, np.float64)
        cur = np.empty((n, 4), np.dtype(config.precision))
        cur[:, :3] = model.rest_pos
        cur[:, 3] = model.inv_mass
        self.state = ImplicitState(cur, cur.copy())
        self._written = cur.copy()
        self.prev_h: float | None = None

        # per-step arrays, allocated once
        self.force = np.zeros((n, 3))
        self.jacobian_v = np.zeros((n, 3))
        self.blocks = self.pattern.empty_values()
        self.rhs = np.zeros((n, 3))
        self.inverse = np.zeros((n, 3, 3))
        self.dv = np.zeros((n, 3))
        self._cg_scratch = [np.zeros((n, 3)) for _ in range(4)]
        self._partial = np.zeros((CHUNKS, 2))
        self.v_mid = np.zeros((n, 3))  # average velocity over the step: x1 = x0 + h v_mid
        self.v_end = np.zeros((n, 3))  # the velocity kept at the end of the step
        self.contact = np.zeros((n, 8))  # last contact per particle (kernels.implicit_collision)
        self.contact[:, 0] = NO_CONTACT
        # the colliders' motion over a frame, posed per step: the position-based stage's
        self.collide_stage = CollideStage(self, faces=False, continuous=True) if self.colliders is not None else None
        self._plan: FramePlan | None = None

        self.last_cg = {"iterations": 0, "residual": 0.0}
        self._frame = self._empty_frame_stats()
        self.stage_names = ["forces", "assemble", "cg-solve"]
        if self.colliders is not None:
            self.stage_names.append("collide")
        if self.params.strain_limit > 0:
            self.stage_names.append("strain-limit")
        if self.has_motion:
            self.stage_names.append("motion")
        self.stage_names.append("integrate")

    # ------------------------------------------------------------------ interface
    @property
    def asleep(self) -> bool:
        return False

    def set_neighbours(self, neighbours) -> None:
        """Accepted for interface compatibility: this integrator has no cloth-cloth collision."""
        self.neighbours = [n for n in neighbours if n is not self]

    def warm_up(self) -> None:
        """Compile (or load from numba's cache) every kernel, on empty inputs."""
        none3 = np.zeros((0, 3))
        no_order, no_offsets = np.zeros(0, np.int32), np.zeros(1, np.int32)
        rest, pattern, blocks = self.rest, self.pattern, self.blocks[:0]
        triangle_terms(rest.triangles[:0], rest.tri_dinv[:0], rest.tri_area[:0], pattern.triangle_slot[:0], no_order,
                       no_offsets, none3, none3, 1.0, 1.0, 1.0, 1.0, 0.0, 1.0, 1.0, False, none3, none3, blocks)
        hinge_terms(rest.hinges[:0], rest.hinge_rest_angle[:0], rest.hinge_weight[:0], pattern.hinge_slot[:0], no_order,
                    no_offsets, none3, none3, 1.0, 0.0, 1.0, 1.0, none3, none3, blocks)
        if self.params.has_air:
            drag_terms(rest.triangles[:0], pattern.triangle_slot[:0], no_order, no_offsets, self.air_share, none3, none3,
                       np.zeros(3), 1.0, 1.0, 1.0, 1.0, none3, blocks)
        block_jacobi(pattern.diagonal_slot[:0], blocks, self.free[:0], self.inverse[:0])
        filtered_pcg(no_offsets, pattern.columns[:0], blocks, self.inverse[:0], self.free[:0], none3, 1e-6, 0.0, 1,
                     none3, none3, none3, none3, none3, self._partial)
        limit_strain(self.edges[:0], self.edge_rest_length[:0], self.inv_mass, no_order, no_offsets, none3, 1.0, 0.1,
                     1, none3, none3)
        if self.collide_stage is not None:
            stage = self.collide_stage
            stage.warm_up_motion()
            shapes, mesh = stage.groups(empty=True)
            collide_particles(shapes, mesh, stage.frame, none3, self.mass[:0], self.free[:0], 1.0, 1.0, 1, none3, none3,
                              self.contact[:0])
            project_particles(shapes, mesh, stage.frame, none3, self.free[:0], 1.0, none3, none3, self.contact[:0])

    def plan_frame(self, frame: int, time: float, frame_dt: float, end_time: float | None = None) -> FramePlan:
        """Plan frame ``frame``, simulated from ``time`` to ``end_time`` (default time + frame_dt)
        in round(frame_dt * config.frequency) steps (at least one)."""
        steps = max(1, int(frame_dt * self.config.frequency + 0.5))
        h = frame_dt / steps
        plan = FramePlan(frame, time, frame_dt, steps, h, self.config.stiffness_frequency * h, end_time)
        if self.prev_h is None:  # the first frame: adopt positions set before it, then publish
            if not np.array_equal(self.state.cur, self._written):
                self.x = self.state.cur[:, :3].astype(np.float64)
            self.prev_h = h
            self._write_state(h)
        self._plan = plan
        self._frame = self._empty_frame_stats()
        if self.collide_stage is not None:
            self.collide_stage.begin_frame(plan)
        return plan

    def iteration(self, plan: FramePlan, index: int) -> Iteration:
        return Iteration(index, index / plan.iterations, (index + 1) / plan.iterations, 1.0, None)

    def step(self, frame: int, time: float, frame_dt: float, end_time: float | None = None) -> FramePlan:
        """Simulate one frame (all its steps) on its own."""
        plan = self.plan_frame(frame, time, frame_dt, end_time)
        for index in range(plan.iterations):
            self.iterate(self.iteration(plan, index))
        return plan

    def run_frame(self, plan: FramePlan) -> bool:
        """Frames run iteration by iteration (the runner calls iteration/iterate)."""
        return False

    def iterate(self, iteration: Iteration) -> None:
        """One implicit step of length plan.h."""
        plan = self._plan
        h = plan.h
        time = plan.time if iteration.index == 0 else plan.iteration_end(iteration.index - 1)
        self._read_state()
        with self._threads():
            with self.profiler.stage("forces"):
                self.compute_forces(h, time)
            with self.profiler.stage("assemble"):
                self.assemble(h)
            with self.profiler.stage("cg-solve"):
                self.solve()
            np.add(self.v, self.dv, out=self.v_mid)
            self.v_end[:] = self.v_mid
            if self.colliders is not None:
                with self.profiler.stage("collide"):
                    self.collide(h, iteration)
            if self.params.strain_limit > 0:
                with self.profiler.stage("strain-limit"):
                    self.limit_strain(h)
            if self.has_motion:
                with self.profiler.stage("motion"):
                    self.constrain_motion(h)
            if self.colliders is not None:
                with self.profiler.stage("collide"):
                    self.project(h)
            with self.profiler.stage("integrate"):
                self.integrate(h)

    def cloth_report(self) -> dict:
        """Integrator-specific facts about the cloth for the bake report (none for this one)."""
        return {}

    def frame_stats(self) -> dict:
        """Totals over the current frame's steps: steps, CG iterations, the largest final
        relative CG residual, particles touching a collider after the last step, and edge
        corrections made by strain limiting."""
        return dict(self._frame)

    # ------------------------------------------------------------------ stages
    def compute_forces(self, h: float, time: float) -> None:
        """Forces at (x, v) into ``force``; -(h^2 df/dx + h df/dv) into ``blocks``;
        (df/dx) v into ``jacobian_v``."""
        rest, pattern, p = self.rest, self.pattern, self.params
        np.multiply(self.mass[:, None], self.gravity[None, :], out=self.force)
        self.jacobian_v.fill(0.0)
        self.blocks.fill(0.0)
        order, offsets = self.triangle_colors
        triangle_terms(rest.triangles, rest.tri_dinv, rest.tri_area, pattern.triangle_slot, order, offsets, self.x,
                       self.v, p.stretch, p.stretch, p.compression, p.shear, p.damping_time, h * h, h, False, self.force,
                       self.jacobian_v, self.blocks)
        if p.has_air:
            wind = np.asarray(self.environment.wind_at(time), np.float64)
            drag_terms(rest.triangles, pattern.triangle_slot, order, offsets, self.air_share, self.x, self.v, wind, p.drag,
                       p.lift,
                       p.air_density, h, self.force, self.blocks)
        order, offsets = self.hinge_colors
        hinge_terms(rest.hinges, rest.hinge_rest_angle, rest.hinge_weight, pattern.hinge_slot, order, offsets, self.x,
                    self.v, p.bend, p.damping_time, h * h, h, self.force, self.jacobian_v, self.blocks)

    def assemble(self, h: float) -> None:
        """A = M + blocks, rhs = h (f + h df/dx v), and the block-Jacobi preconditioner."""
        diagonal = self.pattern.diagonal_slot
        for k in range(3):
            self.blocks[diagonal, k, k] += self.mass
        np.multiply(self.jacobian_v, h, out=self.rhs)
        self.rhs += self.force
        self.rhs *= h
        block_jacobi(diagonal, self.blocks, self.free, self.inverse)

    def solve(self) -> None:
        r, z, c, q = self._cg_scratch
        p = self.params
        # absolute floor: momentum errors worth a velocity error of tolerance * h * |g|
        floor = p.cg_tolerance * self._plan.h * max(float(np.linalg.norm(self.gravity)), 1.0)
        iterations, residual = filtered_pcg(
            self.pattern.row_offsets, self.pattern.columns, self.blocks, self.inverse, self.free, self.rhs,
            p.cg_tolerance, floor * float(np.linalg.norm(self.mass)), p.cg_max_iterations, self.dv, r, z, c, q,
            self._partial,
        )
        self.last_cg = {"iterations": int(iterations), "residual": float(residual)}
        self._frame["steps"] += 1
        self._frame["cg_iterations"] += int(iterations)
        self._frame["cg_max_residual"] = max(self._frame["cg_max_residual"], float(residual))

    def constrain_motion(self, h: float) -> None:
        """End positions outside their max-distance sphere go back onto it; the kept
        velocity loses its outward radial part."""
        offset = self.x + h * self.v_mid - self.rest_pos
        distance = np.linalg.norm(offset, axis=1)
        outside = distance > self.motion_radius
        if not outside.any():
            return
        direction = offset[outside] / distance[outside, None]
        target = self.rest_pos[outside] + direction * self.motion_radius[outside, None]
        self.v_mid[outside] = (target - self.x[outside]) / h
        outward = np.maximum(np.sum(self.v_end[outside] * direction, axis=1), 0.0)
        self.v_end[outside] -= outward[:, None] * direction

    def collide(self, h: float, iteration: Iteration) -> None:
        """Bridson's repulsion, friction and inelastic impulses (``kernels.implicit_collision``,
        steps 1-3), with the colliders posed for the step ``iteration``."""
        stage = self.collide_stage
        stage.pose(iteration)
        shapes, mesh = stage.groups()
        collide_particles(shapes, mesh, stage.frame, self.x, self.mass, self.free, self.params.repulsion, h,
                          COLLISION_PASSES, self.v_mid, self.v_end, self.contact)

    def limit_strain(self, h: float) -> None:
        order, offsets = self.edge_colors
        self._frame["strain_corrections"] += int(limit_strain(
            self.edges, self.edge_rest_length, self.inv_mass, order, offsets, self.x, h, self.params.strain_limit,
            STRAIN_SWEEPS, self.v_mid, self.v_end,
        ))

    def project(self, h: float) -> None:
        """The final robust pass (``kernels.implicit_collision``, step 4), with the colliders
        as ``collide`` posed them."""
        stage = self.collide_stage
        shapes, mesh = stage.groups()
        project_particles(shapes, mesh, stage.frame, self.x, self.free, h, self.v_mid, self.v_end, self.contact)
        self._frame["contacts"] = int(np.count_nonzero(self.contact[:, 0] < NO_CONTACT))

    def integrate(self, h: float) -> None:
        free = self.free != 0
        self.x[free] += h * self.v_mid[free]
        self.v[free] = self.v_end[free]
        self.prev_h = h
        self._write_state(h)

    # ------------------------------------------------------------------ state
    @staticmethod
    def _empty_frame_stats() -> dict:
        return {"steps": 0, "cg_iterations": 0, "cg_max_residual": 0.0, "contacts": 0, "strain_corrections": 0}

    @contextlib.contextmanager
    def _threads(self):
        if not self.single_thread:
            yield
            return
        previous = numba.get_num_threads()
        numba.set_num_threads(1)
        try:
            yield
        finally:
            numba.set_num_threads(previous)

    def _write_state(self, h: float) -> None:
        state = self.state
        state.cur[:, :3] = self.x
        state.prev[:, :3] = self.x - self.v * h
        state.prev[:, 3] = state.cur[:, 3]
        self._written[:] = state.cur

    def _read_state(self) -> None:
        """Take positions and velocities from the state if someone else changed it."""
        state = self.state
        if np.array_equal(state.cur, self._written):
            return
        self.x = state.cur[:, :3].astype(np.float64)
        self.v = (self.x - state.prev[:, :3]) / self.prev_h
        self._written[:] = state.cur

    # ------------------------------------------------------------------ output
    def world_points(self) -> np.ndarray:
        """(n,3) current positions, world space, in the state's precision."""
        return np.ascontiguousarray(self.state.cur[:, :3])

    def cache_rows(self, h: float | None) -> tuple[np.ndarray, np.ndarray | None]:
        """See Integrator.cache_rows."""
        return cache_rows(self, h)

    def world_velocities(self, h: float) -> np.ndarray:
        """f32 (n,3) velocities at the end of the last step (world space, scene units/s)."""
        return ((self.state.cur[:, :3] - self.state.prev[:, :3]) / h).astype(np.float32)
