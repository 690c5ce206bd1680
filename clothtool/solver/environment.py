"""What the scene imposes on every cloth: gravity and the wind (a constant or a track)."""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING, Callable

import numpy as np

if TYPE_CHECKING:  # pragma: no cover
    from clothtool.collision.colliders import ColliderArrays


AIR_DENSITY = 1.2  # kg/m^3 at sea level and room temperature


@dataclasses.dataclass(frozen=True)
class Environment:
    """gravity: (3,) world acceleration in scene units/s^2; wind: time -> (3,) world wind
    velocity in scene units/s (None = still air); fluid_density: the air's density in kg/m^3
    (drag and lift; see clothtool.solver.wind);
    colliders: time in seconds -> world-space ColliderArrays (None = no colliders, and no
    collide stage)."""

    gravity: np.ndarray
    wind: Callable[[float], np.ndarray] | None = None
    fluid_density: float = AIR_DENSITY
    colliders: Callable[[float], "ColliderArrays"] | None = None

    @property
    def has_wind(self) -> bool:
        return self.wind is not None

    def wind_at(self, time: float) -> np.ndarray:
        return np.zeros(3) if self.wind is None else np.asarray(self.wind(time), np.float64)
