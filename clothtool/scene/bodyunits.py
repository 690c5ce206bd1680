"""Bodies read from files in other units than the scene's, brought into scene units.

A body file says its units (USD's ``metersPerUnit`` and ``upAxis``, glTF's metres and Y up);
a TOML scene says its own. The body is scaled by ``file metres per unit / scene metres per
unit`` and turned from its up axis to the scene's, as one change C in front of everything the
file places: ``world_scene = C @ world_file``. A body on a track keeps its local geometry and
gets C folded into every key (C = s R is a uniform scale times a rotation, so
``C (T R_k S_k) = T(s R t_k) (R R_k) (s S_k)`` is again a key); a body whose points are already
in the world (skinned, or still with no track) has its points moved.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from clothtool.mesh.units import unit_change
from clothtool.scene.colliders import Collider
from clothtool.scene.tracks import Track, matrix_to_quat, quat_multiply


def _points(points: np.ndarray | None, scale: float, rotation: np.ndarray) -> np.ndarray | None:
    return None if points is None else scale * (points @ rotation.T)


def _track(track: Track, scale: float, rotation: np.ndarray) -> Track:
    turn = matrix_to_quat(rotation)
    return dataclasses.replace(
        track,
        translations=scale * (track.translations @ rotation.T),
        rotations=np.stack([quat_multiply(turn, q) for q in track.rotations]),
        scales=scale * track.scales,
    )


def body_in_scene_units(body: Collider, file_mpu: float, file_up: str, scene_mpu: float, scene_up: str) -> Collider:
    """``body`` (geometry, track and thickness in the file's units) in the scene's units."""
    scale, rotation = unit_change(file_mpu, file_up, scene_mpu, scene_up)
    if scale == 1.0 and np.array_equal(rotation, np.eye(3)):
        return body
    if body.track is not None:
        return dataclasses.replace(body, track=_track(body.track, scale, rotation), thickness=scale * body.thickness)
    planes = body.planes.copy()
    planes[:, :3] = planes[:, :3] @ rotation.T
    planes[:, 3] *= scale
    return dataclasses.replace(
        body,
        thickness=scale * body.thickness,
        centers=scale * (body.centers @ rotation.T),
        radii=scale * body.radii,
        planes=planes,
        mesh_points=_points(body.mesh_points, scale, rotation),
        deform_points=_points(body.deform_points, scale, rotation),
        rest_points=_points(body.rest_points, scale, rotation),
    )
