"""Settings shared by the scene, the solvers and the bake: solver and material settings
(frozen dataclasses filled from presets and overrides) and where a cloth goes (placement,
motion constraints, backstops). A neutral module: it imports no scene, solver or io code.

Stiffness-like values in [0,1] follow NvCloth: a stiffness k removes the fraction k of a
constraint's error per step of the *stiffness frequency*; the solver converts it to its own
iteration rate in log space (see ``clothtool.solver.logstiffness``). Lengths are in metres
and converted to scene units by the bake.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Literal

import numpy as np

from clothtool.errors import PresetError
from clothtool.presets import apply_mapping, load_preset


@dataclasses.dataclass(frozen=True)
class PhaseSettings:
    """How one constraint phase behaves (NvCloth's PhaseConfig).

    stiffness: fraction of the error removed per stiffness-frequency step, in [0,1].
    stiffness_multiplier: stiffness factor, in [0,1], inside the band between the
        compression and stretch limits (1 = no band).
    compression_limit: the band's lower edge as a length ratio <= 1 (1 = no band).
    stretch_limit: the band's upper edge as a length ratio >= 1 (1 = no band).
    """

    stiffness: float = 1.0
    stiffness_multiplier: float = 1.0
    compression_limit: float = 1.0
    stretch_limit: float = 1.0

    def check(self, where: str) -> None:
        for key in ("stiffness", "stiffness_multiplier"):
            value = getattr(self, key)
            if not 0.0 <= value <= 1.0:
                raise PresetError(f"{where}: key '{key}' = {value:g} must lie in [0, 1]")
        if not 0.0 < self.compression_limit <= 1.0:
            raise PresetError(f"{where}: key 'compression_limit' = {self.compression_limit:g} must lie in (0, 1]")
        if self.stretch_limit < 1.0:
            raise PresetError(f"{where}: key 'stretch_limit' = {self.stretch_limit:g} must be at least 1")


def _unit(where: str, key: str, value: float, low: float = 0.0, high: float = 1.0) -> None:
    if not low <= value <= high:
        raise PresetError(f"{where}: key '{key}' = {value:g} must lie in [{low:g}, {high:g}]")


@dataclasses.dataclass(frozen=True)
class Material:
    """A cloth material (presets/material/*.toml). Units: SI (kg, m, s)."""

    areal_density: float = 0.15
    thickness: float = 0.002
    vertical: PhaseSettings = PhaseSettings()
    horizontal: PhaseSettings = PhaseSettings()
    shearing: PhaseSettings = PhaseSettings(stiffness=0.8)
    bending: PhaseSettings = PhaseSettings(stiffness=0.3)
    # physical moduli for stiffness_mode = "xpbd"
    stretch_modulus: float = 5000.0
    shear_modulus: float = 500.0
    bend_modulus: float = 1e-5
    damping: float = 0.1
    linear_drag: float = 0.0
    angular_drag: float = 0.0
    linear_inertia: float = 1.0
    angular_inertia: float = 1.0
    tether_stiffness: float = 1.0
    tether_scale: float = 1.0
    drag_coefficient: float = 0.0
    lift_coefficient: float = 0.0
    friction: float = 0.5
    collision_mass_scale: float = 0.0
    self_collision_distance: float = 0.0
    self_collision_stiffness: float = 1.0

    def check(self, where: str) -> None:
        for name in ("vertical", "horizontal", "shearing", "bending"):
            getattr(self, name).check(f"{where}.{name}")
        if not self.areal_density > 0:
            raise PresetError(f"{where}: key 'areal_density' = {self.areal_density:g} must be positive (kg/m^2)")
        if self.thickness < 0:
            raise PresetError(f"{where}: key 'thickness' = {self.thickness:g} must not be negative (m)")
        for key in ("stretch_modulus", "shear_modulus", "bend_modulus"):
            if getattr(self, key) < 0:
                raise PresetError(f"{where}: key '{key}' must not be negative")
        for key in ("damping", "linear_drag", "angular_drag", "linear_inertia", "angular_inertia",
                    "tether_stiffness", "drag_coefficient", "lift_coefficient", "self_collision_stiffness"):
            _unit(where, key, getattr(self, key))
        if self.tether_scale <= 0:
            raise PresetError(f"{where}: key 'tether_scale' = {self.tether_scale:g} must be positive")
        if self.friction < 0 or self.collision_mass_scale < 0 or self.self_collision_distance < 0:
            raise PresetError(f"{where}: friction, collision_mass_scale and self_collision_distance must not be negative")

    def phase(self, label: str) -> PhaseSettings:
        return getattr(self, label)


@dataclasses.dataclass(frozen=True)
class SolverConfig:
    """How the solver runs (presets/solver/*.toml).

    frequency: solver iterations per second (iterations per frame = round(frequency / fps)).
    stiffness_frequency: the rate (Hz) at which stiffness values are specified.
    stiffness_mode: "nvcloth" (log-space stiffness, as NvCloth) or "xpbd" (compliance from
        the material's physical moduli; converges with frequency).
    integrator: "pbd" (NvCloth's position-based solver), "implicit" or "explicit".
    parallel_threshold: collision, self-collision and the other integrators' work over at
        least this many particles or constraints runs on all cores.
    fabric_parallel_threshold: the position-based fabric is solved on all cores when a set,
        or a layer of cache tiles solved at once (clothtool.solver.fabric_layers), holds at
        least this many constraints (the kernel does ~3 ns per constraint, so the work must
        be large for two threads to beat one). Either way the bits are identical.
    precision: the particle state's dtype, "float64" (default) or "float32". float64 state
        converges as the frequency rises: position Verlet adds g h^2 to a stored position each
        iteration, which at 3840 Hz (6.7e-7 m) is below a float32 ulp of any coordinate
        beyond ~8 m, so in float32 free fall over 1 s is off by 5% at 3840 Hz and a cloth at
        y = 40 m stops falling; the pendulum period stops converging at ~0.4%. float32 bakes
        about 1.4-1.6x faster (benchmarks/bake.py --precision float32,float64) and is fine up
        to a few hundred Hz near the origin. Caches store float32 positions either way.
    max_speed: a particle faster than this (m/s) marks the bake unstable.
    sleep_threshold: m/s below which a cloth counts as still (0 disables sleeping).
    sleep_test_interval: seconds between sleep tests; sleep_after_count: still tests in a
        row before the cloth sleeps.
    force: run the explicit integrator even beyond its stability limit (``--force``).
    cg_tolerance, cg_max_iterations: the implicit integrator's conjugate-gradient solve.
    compression_ratio: implicit: stiffness of a compressed axis relative to stretching.
    strain_limit: implicit: edges are kept within this strain after collisions (0 = off).
    cloth_collision: cloths of a scene keep their particles apart (each material's
        self_collision_distance; a pair keeps the larger of the two).
    face_collision: position-based: faces collide with spheres and capsules, not only
        particles: each triangle too large for the smallest one (clothtool.solver.facepoints)
        pushes its deepest point out of each (clothtool.solver.kernels.collide_faces), so no
        face sinks into a collider between particles. Not with continuous_collision against
        spheres and capsules (a sheet swept over a rod thinner than its triangles wraps flat
        faces round it, and their discrete, conflicting corrections inject speed). Against triangle-mesh colliders the faces collide with the
        mesh's vertices and edge samples (clothtool.solver.meshfaces), with continuous
        collision too: those contacts catch crossings themselves.
    """

    frequency: float = 300.0
    stiffness_frequency: float = 100.0
    stiffness_mode: Literal["nvcloth", "xpbd"] = "nvcloth"
    integrator: Literal["pbd", "implicit", "explicit"] = "pbd"
    precision: Literal["float32", "float64"] = "float64"
    parallel_threshold: int = 6000
    # A 128^2 cloth's sets (~8000 constraints) solve faster on one core than on two; a 255^2
    # cloth's (~32000) gain 25% wall time (python benchmarks/bake.py --fabric-parallel-threshold).
    fabric_parallel_threshold: int = 20000
    max_speed: float = 200.0
    sleep_threshold: float = 0.0
    sleep_test_interval: float = 0.1
    sleep_after_count: int = 10
    continuous_collision: bool = False
    self_collision: bool = False
    force: bool = False
    cg_tolerance: float = 1e-6
    cg_max_iterations: int = 200
    compression_ratio: float = 0.1
    strain_limit: float = 0.1
    cloth_collision: bool = False
    face_collision: bool = True

    def check(self, where: str) -> None:
        for key in ("frequency", "stiffness_frequency"):
            value = getattr(self, key)
            if not (value > 0 and math.isfinite(value)):
                raise PresetError(f"{where}: key '{key}' = {value:g} must be a positive, finite number of iterations per second")
        if not self.max_speed > 0:
            raise PresetError(f"{where}: key 'max_speed' must be positive")
        if self.sleep_threshold < 0 or self.sleep_test_interval <= 0 or self.sleep_after_count < 1:
            raise PresetError(f"{where}: sleep_threshold >= 0, sleep_test_interval > 0 and sleep_after_count >= 1 are required")
        for key in ("parallel_threshold", "fabric_parallel_threshold"):
            if getattr(self, key) < 1:
                raise PresetError(f"{where}: key '{key}' must be at least 1")
        if not self.cg_tolerance > 0 or self.cg_max_iterations < 1:
            raise PresetError(f"{where}: cg_tolerance must be positive and cg_max_iterations at least 1")


_EXAMPLE = {"material": "cotton", "solver": "production"}


def _load_settings(kind: str, cls, name_or_table: str | dict, where: str):
    """Settings of ``cls`` from a preset of ``kind`` named by a string, or from a table with an
    optional ``preset`` key plus overrides; checked."""
    if not isinstance(name_or_table, (str, dict)):
        raise PresetError(f"{where}: expected a {kind} preset name or a table, got {name_or_table!r}; e.g. {kind} = \"{_EXAMPLE[kind]}\"")
    table = {"preset": name_or_table} if isinstance(name_or_table, str) else dict(name_or_table)
    settings = cls()
    preset = table.pop("preset", None)
    if preset is not None:
        mapping, label = load_preset(kind, preset)
        settings = apply_mapping(settings, mapping, label)
    settings = apply_mapping(settings, table, where)
    settings.check(where)
    return settings


def load_material(name_or_table: str | dict, where: str) -> Material:
    """A material from a preset name, or a table with an optional ``preset`` key plus overrides."""
    return _load_settings("material", Material, name_or_table, where)


def load_solver(name_or_table: str | dict, where: str) -> SolverConfig:
    """Solver settings from a preset name, or a table with an optional ``preset`` key plus overrides."""
    return _load_settings("solver", SolverConfig, name_or_table, where)


@dataclasses.dataclass(frozen=True)
class Placement:
    """Where a fabric goes in the scene: scene = rotation @ (scale * fabric) + translation,
    after converting the fabric's units and up axis to the scene's."""

    scale: float = 1.0
    rotation: np.ndarray = dataclasses.field(default_factory=lambda: np.eye(3))
    translation: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(3))


@dataclasses.dataclass(frozen=True)
class MotionSettings:
    """Motion constraints (max distance): radius = painted * scale + bias, scene units."""

    scale: float = 1.0
    bias: float = 0.0
    stiffness: float = 1.0


@dataclasses.dataclass(frozen=True)
class BackstopSettings:
    """Separation spheres behind each particle: the particle stays outside a sphere of
    ``radius`` whose surface lies ``distance`` behind its rest position (against the normal).
    Scene units."""

    radius: float
    distance: float = 0.0
