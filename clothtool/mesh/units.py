"""Length units and up axes: the one place that says how coordinates written in one file's
units (metres per unit, Y or Z up) become another's."""

from __future__ import annotations

import numpy as np

from clothtool.errors import SceneError

# Rotations taking one up axis to another (columns: where the source axes go). Z-up to Y-up
# turns +Z (up) onto +Y and +Y (forward) onto -Z, as DCCs do when they change the up axis.
_Z_UP_TO_Y_UP = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])


def up_axis_rotation(source: str, target: str) -> np.ndarray:
    """Rotation matrix taking coordinates with up axis ``source`` to up axis ``target``."""
    if source == target:
        return np.eye(3)
    if (source, target) == ("Z", "Y"):
        return _Z_UP_TO_Y_UP.copy()
    if (source, target) == ("Y", "Z"):
        return _Z_UP_TO_Y_UP.T.copy()
    raise SceneError(f"unknown up axes {source!r} -> {target!r}; use Y or Z")


def unit_change(source_mpu: float, source_up: str, target_mpu: float, target_up: str) -> tuple[float, np.ndarray]:
    """(scale, rotation (3,3)): ``target = scale * rotation @ source`` for coordinates written
    in ``source_mpu`` metres per unit with ``source_up`` up, read in the target's units."""
    return float(source_mpu) / float(target_mpu), up_axis_rotation(source_up, target_up)
