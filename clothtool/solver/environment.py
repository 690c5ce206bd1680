"""What the scene imposes on every cloth: gravity and the wind (a constant or a track)."""

from __future__ import annotations

import dataclasses
from typing import Callable

import numpy as np


@dataclasses.dataclass(frozen=True)
class Environment:
    """gravity: (3,) world acceleration in scene units/s^2; wind: time -> (3,) world wind
    velocity in scene units/s (None = still air); fluid_density: NvCloth's fluid density,
    which scales drag and lift (it compensates for the doubled triangle area)."""

    gravity: np.ndarray
    wind: Callable[[float], np.ndarray] | None = None
    fluid_density: float = 1.0

    @property
    def has_wind(self) -> bool:
        return self.wind is not None

    def wind_at(self, time: float) -> np.ndarray:
        return np.zeros(3) if self.wind is None else np.asarray(self.wind(time), np.float64)
