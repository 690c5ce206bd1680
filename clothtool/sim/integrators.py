"""The integrator contract: what every integrator offers the bake, which integrators exist,
and what each can do.

The bake drives any integrator through ``Integrator`` (one instance per cloth). Each
integrator declares its capabilities; ``check_capabilities`` compares them with what a scene
asks for and refuses a scene that asks for something its integrator cannot do, naming the
scene key, instead of ignoring it. What an integrator does without (a position-based device
such as tethers, which the force-based integrators replace with stiff stretch) is declared
too and listed in the bake report.
"""

from __future__ import annotations

import dataclasses
import importlib
from typing import TYPE_CHECKING, Protocol

import numpy as np

from clothtool.errors import SceneError

if TYPE_CHECKING:  # pragma: no cover
    from clothtool.scene.scene import Scene
    from clothtool.solver.iteration import FramePlan, Iteration
    from clothtool.solver.model import ClothModel


class Integrator(Protocol):
    """One cloth's solver, as the bake drives it (see clothtool.bake)."""

    model: "ClothModel"
    stage_names: list[str]

    @property
    def asleep(self) -> bool: ...

    def set_neighbours(self, neighbours) -> None:
        """The scene's other cloths (cloth-cloth collision); before the first frame."""

    def warm_up(self) -> None:
        """Compile the kernels this cloth's stages use."""

    def plan_frame(self, frame: int, time: float, frame_dt: float, end_time: float | None = None) -> "FramePlan": ...

    def iteration(self, plan: "FramePlan", index: int) -> "Iteration": ...

    def iterate(self, iteration: "Iteration") -> None: ...

    def run_frame(self, plan: "FramePlan") -> bool:
        """Run all iterations of the planned frame at once and return True, or return False
        (doing nothing) when the integrator runs its frames through iteration/iterate."""

    def step(self, frame: int, time: float, frame_dt: float, end_time: float | None = None) -> "FramePlan": ...

    def frame_stats(self) -> dict:
        """Integrator-specific figures of the last frame for the report ({} when none)."""

    def world_points(self) -> np.ndarray: ...

    def world_velocities(self, h: float) -> np.ndarray: ...

    def cache_rows(self, h: float | None) -> tuple[np.ndarray, np.ndarray | None]:
        """What a cache frame stores: f32 (n,3) world points and, given the last iteration's
        length h, world velocities, in the mesh's vertex order (clothtool.solver.cache_rows
        makes them from world_points and world_velocities)."""


# Capabilities a scene can ask for, with the scene key that asks.
CAPABILITIES = {
    "tracks": "a cloth that follows a track (cloth.NAME.track)",
    "attachments": "pinned particles that follow an animated body (cloth.NAME.attach)",
    "motion": "painted max-distance motion constraints (the fabric's max distance)",
    "separation": "backstop separation spheres (cloth.NAME.backstop)",
    "collision": "collision with the scene's colliders ([[collider]] tables)",
    "continuous_collision": "continuous collision (solver.continuous_collision)",
    "self_collision": "self-collision (solver.self_collision)",
    "cloth_collision": "cloth-cloth collision (solver.cloth_collision)",
    "sleep": "sleeping (solver.sleep_threshold > 0)",
}


@dataclasses.dataclass(frozen=True)
class IntegratorSpec:
    """A registered integrator: where its class lives (imported only when used), what it can
    do, and what it does without (feature -> why)."""

    name: str
    module: str
    class_name: str
    capabilities: frozenset[str]
    does_without: dict[str, str] = dataclasses.field(default_factory=dict)

    def load(self):
        return getattr(importlib.import_module(self.module), self.class_name)


_FORCES_HOLD = "the stretch forces and the strain limit hold the cloth; tethers are a position-based device"
REGISTRY: dict[str, IntegratorSpec] = {
    "pbd": IntegratorSpec("pbd", "clothtool.solver.cloth", "ClothSolver", frozenset(CAPABILITIES)),
    "implicit": IntegratorSpec(
        "implicit", "clothtool.integrators.implicit.solver", "ImplicitClothSolver",
        frozenset({"motion", "collision", "continuous_collision"}),
        {"tethers": _FORCES_HOLD},
    ),
    "explicit": IntegratorSpec(
        "explicit", "clothtool.integrators.explicit.solver", "ExplicitClothSolver",
        frozenset({"collision", "continuous_collision"}),
        {"tethers": "spring forces hold the cloth; tethers are a position-based device"},
    ),
}


def integrator_spec(name: str) -> IntegratorSpec:
    if name not in REGISTRY:
        raise SceneError(f"solver.integrator = {name!r} is not an integrator; use one of {', '.join(REGISTRY)}")
    return REGISTRY[name]


def requested_capabilities(scene: "Scene") -> dict[str, str]:
    """capability -> the first place in ``scene`` that asks for it."""
    asked: dict[str, str] = {}
    solver = scene.solver
    if scene.colliders is not None and len(scene.colliders):
        asked["collision"] = "the scene's colliders"
    if solver.continuous_collision and scene.colliders is not None and len(scene.colliders):
        asked["continuous_collision"] = "solver.continuous_collision = true"
    if solver.self_collision:
        asked["self_collision"] = "solver.self_collision = true"
    if solver.cloth_collision and len(scene.cloths) > 1:
        asked["cloth_collision"] = "solver.cloth_collision = true"
    if solver.sleep_threshold > 0:
        asked["sleep"] = f"solver.sleep_threshold = {solver.sleep_threshold:g}"
    for cloth in scene.cloths:
        where = f"cloth.{cloth.name}"
        if cloth.track is not None:
            asked.setdefault("tracks", f"{where}.track")
        if cloth.attach:
            asked.setdefault("attachments", f"{where}.attach")
        if cloth.backstop is not None:
            asked.setdefault("separation", f"{where}.backstop")
        if np.isfinite(cloth.fabric.particle_max_distance).any():
            asked.setdefault("motion", f"{where}: its fabric's painted max distance")
    return asked


def check_capabilities(scene: "Scene") -> IntegratorSpec:
    """The scene's integrator, after refusing a scene that asks for what it cannot do."""
    spec = integrator_spec(scene.solver.integrator)
    for capability, where in requested_capabilities(scene).items():
        if capability not in spec.capabilities:
            can = [name for name, other in REGISTRY.items() if capability in other.capabilities]
            raise SceneError(
                f"{scene.path.name}: {where} asks for {CAPABILITIES[capability]}, which the {spec.name} integrator "
                f"does not do; remove it or use solver.integrator = {' or '.join(repr(c) for c in can)}"
            )
    return spec
