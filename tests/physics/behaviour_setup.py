"""Columns and scene builders of the behavioural physics table (test_behaviour_table.py).

Columns: every registered integrator (clothtool.sim.integrators.REGISTRY) in the solver
presets that select it; the position-based one in both stiffness modes, since they promise
different answers (``production``: NvCloth's log-space stiffness, which converges to an
inextensible cloth; ``physical``: XPBD compliance from the material's moduli, which converges
to linear elasticity). An integrator missing from PRESETS runs in the preset named after it.

Scenes are built as the bake builds them (build_model, Environment, the registry's class);
every measurement here is float64 numpy, independent of the solvers' kernels.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from clothtool.cook.cooker import CookOptions, cook_fabric
from clothtool.integrators.explicit.stability import stability_limit
from clothtool.mesh.shapes import grid
from clothtool.profile import StageProfiler
from clothtool.settings import Material, Placement, SolverConfig, load_solver
from clothtool.sim.integrators import CAPABILITIES, REGISTRY
from clothtool.solver.environment import Environment
from clothtool.solver.model import build_model

G = 9.81
FPS = 60.0

# integrator -> the solver presets it runs in (default: the preset named after the integrator)
PRESETS = {"pbd": ("production", "physical")}


@dataclasses.dataclass(frozen=True)
class Column:
    """One column of the table: an integrator in one solver preset."""

    integrator: str
    preset: str

    @property
    def name(self) -> str:
        return self.integrator if self.preset == self.integrator else f"{self.integrator}/{self.preset}"

    @property
    def capabilities(self) -> frozenset[str]:
        return REGISTRY[self.integrator].capabilities

    def config(self, frequency: float, **overrides) -> SolverConfig:
        """The preset's settings at ``frequency`` in float64 state (the default precision)."""
        config = load_solver(self.preset, f"behaviour table column {self.name}")
        return dataclasses.replace(config, frequency=float(frequency), precision="float64", **overrides)

    @property
    def elastic(self) -> bool:
        """True when the column promises the material's linear elasticity; False for
        NvCloth's stiffness, which converges to an inextensible cloth by design."""
        config = self.config(300.0)
        return config.integrator != "pbd" or config.stiffness_mode == "xpbd"


    def settling(self) -> tuple[float, dict]:
        """(Material.damping, SolverConfig overrides) that bring a hanging cloth to rest within
        a few seconds; statics do not depend on them. Each integrator reads damping its own
        way: position-based, the fraction of velocity removed per stiffness-frequency step
        (0.3 at 100 Hz: e^-36 per second); explicit, each spring's damping ratio (1: critical);
        implicit, a stiffness-proportional time constant damping / stiffness_frequency (1 / 30 Hz:
        33 ms, which damps the strip's and the chain's lowest modes within a second)."""
        if self.integrator == "explicit":
            return 1.0, {}
        if self.integrator == "implicit":
            return 1.0, {"stiffness_frequency": 30.0}
        return 0.3, {}


def columns() -> list[Column]:
    return [Column(name, preset) for name in REGISTRY for preset in PRESETS.get(name, (name,))]


def skip_reason(column: Column, requires: frozenset[str]) -> str | None:
    """Why ``column`` cannot run a case that needs ``requires`` (None: it can), from the
    integrator's declared capabilities."""
    missing = sorted(requires - column.capabilities)
    if not missing:
        return None
    return f"the {column.integrator} integrator declares no " + "; no ".join(CAPABILITIES[c] for c in missing)


# ---------------------------------------------------------------------------------- solvers
def make_solver(column: Column, fabric, material: Material, frequency: float, gravity=(0.0, -G, 0.0),
                colliders=None, fluid_density: float = 1.2, initial_velocity=(0.0, 0.0, 0.0), **config_overrides):
    """A solver of ``column`` for ``fabric`` placed as is in a metre, Y-up scene."""
    model = build_model("cloth", fabric, material, Placement(), 1.0, "Y")
    config = column.config(frequency, **config_overrides)
    call = None if colliders is None else (lambda t: colliders)
    environment = Environment(gravity=np.asarray(gravity, np.float64), fluid_density=fluid_density, colliders=call)
    extra = {"frame_dt": 1.0 / FPS} if column.integrator == "explicit" else {}
    solver_class = REGISTRY[column.integrator].load()
    return solver_class(model, config, environment, StageProfiler(), None, frozenset(), initial_velocity, **extra)


def explicit_frequencies(column: Column, fabric, material: Material, ladder, **environment) -> tuple:
    """``ladder`` doubled until its first rung is inside the explicit integrator's stability
    limit for this scene (other columns: ``ladder`` as it is)."""
    if column.integrator != "explicit":
        return tuple(ladder)
    model = build_model("cloth", fabric, material, Placement(), 1.0, "Y")
    env = Environment(gravity=np.array([0.0, -G, 0.0]), fluid_density=environment.get("fluid_density", 1.2))
    limit = stability_limit(model, env if material.drag_coefficient > 0 else None)
    factor = 1
    while 1.0 / (ladder[0] * factor) >= 0.8 * limit:
        factor *= 2
    return tuple(f * factor for f in ladder)


def iteration_length(frequency: float) -> float:
    """h of every solver at ``frequency`` with FPS frames (round(frequency / FPS) per frame)."""
    return 1.0 / FPS / max(1, int(frequency / FPS + 0.5))


def run(solver, seconds: float, first: int = 1, each=None) -> None:
    """Frames ``first``.. covering ``seconds``, as the bake drives them."""
    dt = 1.0 / FPS
    for frame in range(first, first + round(seconds * FPS)):
        solver.step(frame, (frame - 1) * dt, dt)
        if each is not None:
            each(frame * dt)


def positions(solver) -> np.ndarray:
    """A float64 copy of the world positions (some integrators return a view of their state)."""
    return np.array(solver.world_points(), np.float64)


def velocities(solver, h: float) -> np.ndarray:
    """float64 (n,3) velocities: the integrator's own where it keeps one, else the last
    iteration's displacement over h."""
    if hasattr(solver, "velocity"):  # explicit: symplectic Euler's v
        return np.asarray(solver.velocity, np.float64).copy()
    if hasattr(solver, "v"):  # implicit: backward Euler's v
        return np.asarray(solver.v, np.float64).copy()
    state = solver.state
    return (state.cur[:, :3].astype(np.float64) - state.prev[:, :3]) / h


def start_at(solver, points: np.ndarray) -> None:
    """Place the particles at ``points`` (n,3), at rest, before the first frame (every
    integrator derives its start from state.cur then)."""
    solver.state.cur[:, :3] = points
    solver.state.prev[:, :3] = points


def masses(solver) -> np.ndarray:
    """float64 (n,) the masses the integrator moves the particles with: the implicit one keeps
    its own float64 masses, the others the inverse of the state's (float32) inverse masses."""
    if hasattr(solver, "mass"):
        return np.asarray(solver.mass, np.float64)
    w = solver.state.prev[:, 3].astype(np.float64)
    return np.where(w > 0, 1.0 / np.where(w > 0, w, 1.0), 0.0)


def add_velocity(solver, dv: np.ndarray, h: float) -> None:
    """Add ``dv`` (n,3) to every particle's velocity between frames."""
    if hasattr(solver, "velocity"):
        solver.velocity += dv.astype(solver.velocity.dtype)
        solver.state.prev[:, :3] -= (dv * h).astype(solver.state.prev.dtype)
    elif hasattr(solver, "v"):
        solver.v += dv
        solver.state.prev[:, :3] -= (dv * h).astype(solver.state.prev.dtype)
    else:  # position Verlet: the velocity is (cur - prev) / h
        solver.state.prev[:, :3] -= (dv * h).astype(solver.state.prev.dtype)


# ---------------------------------------------------------------------------------- fabrics
def single_particle(position, area: float = 1.0):
    """One free particle of ``area`` m^2 (mass = areal density x area)."""
    from tests.physics.conftest import fabric_from_arrays

    return fabric_from_arrays([position], [1.0 / area], area=area)


def ribbon(points_xy, width: float, pinned_rows=(), area: float | None = None, shearing: bool = True,
           bending: bool = False):
    """A cooked ribbon two particles wide: row r at (x_r, y_r, 0) and (x_r, y_r, width), quads
    between consecutive rows, no tethers; rows ``pinned_rows`` pinned. Every particle gets the
    lumped area ``area`` (default: half a band, link x width / 2) so that rows have equal
    masses, and the stretch springs of a band (k = modulus A / L^2 each, clothtool.solver.fabric)
    and the Baraff-Witkin band (Y width / L) agree."""
    xy = np.asarray(points_xy, np.float64)
    rows = xy.shape[0]
    mesh = grid(2, rows, 1.0, quads=True, plane="XY")
    pos = np.zeros((2 * rows, 3))
    pos[0::2, :2] = xy
    pos[1::2, :2] = xy
    pos[1::2, 2] = width
    mesh = dataclasses.replace(mesh, vertex_pos=pos.astype(np.float32))
    fabric = cook_fabric(mesh, CookOptions(tethers="none", shearing=shearing, bending=bending, reorder=False)).fabric
    link = float(np.linalg.norm(np.diff(xy, axis=0), axis=1).mean())
    a = link * width / 2 if area is None else area
    inv_mass = np.full(2 * rows, 1.0 / a)
    for r in pinned_rows:
        inv_mass[[2 * (r % rows), 2 * (r % rows) + 1]] = 0.0
    return fabric.replace(particle_area=np.full(2 * rows, a, np.float32), particle_inv_mass=inv_mass.astype(np.float32))


def cooked_sheet(columns_: int, rows: int, spacing: float, plane: str = "XZ", **options):
    return cook_fabric(grid(columns_, rows, spacing, quads=True, plane=plane), CookOptions(tethers="none", reorder=False, **options)).fabric


def rotated_about_x(fabric, angle: float):
    """``fabric`` with its rest pose turned by ``angle`` about the X axis (rigidly: rest lengths
    and areas unchanged)."""
    c, s = math.cos(angle), math.sin(angle)
    rotation = np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])
    return fabric.replace(rest_pos=(fabric.rest_pos.astype(np.float64) @ rotation.T).astype(np.float32))


# ---------------------------------------------------------------------------------- colliders
def half_space(normal, friction: float):
    """A convex of one plane through the origin, solid where normal . x < 0."""
    from clothtool.collision.colliders import ColliderArrays

    one = np.ones(1, np.float32)
    return ColliderArrays(
        plane=np.asarray([[*normal, 0.0]], np.float32), convex_plane_offsets=np.array([0, 1], np.int32),
        convex_margin=0 * one, convex_friction=friction * one,
    )


# ---------------------------------------------------------------------------------- closed forms
def crossing_times(times, values) -> np.ndarray:
    """Times at which the sampled signal changes sign, interpolated linearly."""
    t = np.asarray(times, np.float64)
    x = np.asarray(values, np.float64)
    i = np.flatnonzero(np.sign(x[:-1]) * np.sign(x[1:]) < 0)
    return t[i] - x[i] * (t[i + 1] - t[i]) / (x[i + 1] - x[i])


def elastic_catenary(masses: int, link: float, span: float, row_weight: float, band_stiffness: float) -> np.ndarray:
    """(masses+2, 2) nodes of a chain of ``masses`` equal weights between two pinned ends at
    the same height ``span`` apart, on masses+1 links of rest length ``link`` whose tension T
    stretches them to link (1 + T / band_stiffness) (inf: inextensible). At rest the horizontal
    tension H is the same in every link and link k carries the vertical load
    V_k = row_weight (k - masses / 2); H is fixed by the span (brentq, float64)."""
    from scipy.optimize import brentq

    vertical = row_weight * (np.arange(masses + 1) - masses / 2.0)

    def links(h):
        tension = np.hypot(h, vertical)
        length = link * (1.0 + tension / band_stiffness)
        return length * h / tension, length * vertical / tension

    def span_error(h):
        return float(links(h)[0].sum()) - span

    h = brentq(span_error, 1e-9 * row_weight, 1e9 * row_weight, xtol=1e-15, rtol=1e-15)
    dx, dy = links(h)
    return np.column_stack([np.concatenate([[0.0], np.cumsum(dx)]), np.concatenate([[0.0], np.cumsum(dy)])])
