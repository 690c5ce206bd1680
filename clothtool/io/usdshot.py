"""A USD layer over the shot: the baked cloth as overrides of the garments' own prims.

The layer sublayers the input shot (by a path relative to the layer, so the pair can move
together) and overrides each garment Mesh prim's ``points``, ``extent`` and, when asked,
``velocities`` at every frame, in the prim's own space (the prim's local-to-world transform
at each frame is undone). Opening the layer in usdview or a DCC shows the animated body and
the baked cloth in one stage. The garment keeps its own topology: baked particles are mapped
back to the mesh's vertices (the cook welds UV-seam duplicates into one particle).
"""

from __future__ import annotations

import contextlib
import os
from pathlib import Path

import numpy as np
from pxr import Sdf, Tf, Usd, UsdGeom

from clothtool import __version__
from clothtool.errors import ClothtoolError, FormatError
from clothtool.io.cache import CacheHeader, CacheOptions, FrameData
from clothtool.io.cache_common import as_points, points_extent
from clothtool.io.usdcache import UsdLayerWriter, _first_line, _layer_args  # first: sets pxr up for crate files
from clothtool.io.vt_points import vec3f_array


class ShotLayerWriter(UsdLayerWriter):
    """Stream frames into a layer over ``scene``'s USD stage (see the module docstring)."""

    def __init__(self, path: Path, scene, options: CacheOptions = CacheOptions()):
        super().__init__(path, options)
        self._shot = Path(scene.path)
        self._cloths = {c.name: c for c in scene.cloths}
        missing = [c.name for c in scene.cloths if c.prim is None]
        if missing:
            raise FormatError(f"{path}: cloth '{missing[0]}' comes from no USD prim; a layer over the shot needs a USD stage scene")
        self._stage = None
        self._targets: list[dict] = []

    def write_header(self, header: CacheHeader) -> None:
        self._check_new_header(header)
        with contextlib.suppress(FileNotFoundError):
            self._tmp.unlink()
        try:
            layer = Sdf.Layer.CreateNew(str(self._tmp), _layer_args(self.path))
        except Tf.ErrorException as exc:
            raise ClothtoolError(f"{self.path}: cannot create the USD layer ({_first_line(exc)}); check the directory is writable") from None
        shot = Usd.Stage.Open(str(self._shot))
        layer.subLayerPaths.append(Path(os.path.relpath(self._shot.resolve(), self.path.resolve().parent)).as_posix())
        # the shot's default prim, else the garment's top-level prim (a stage needs one)
        first_cloth = Sdf.Path(next(iter(self._cloths.values())).prim)
        layer.defaultPrim = shot.GetRootLayer().defaultPrim or first_cloth.GetPrefixes()[0].name
        layer.timeCodesPerSecond = float(header.fps)
        layer.framesPerSecond = float(header.fps)
        layer.startTimeCode = float(header.start_frame)
        layer.endTimeCode = float(header.start_frame)
        layer.customLayerData = {"clothtool": {"generator": f"clothtool {__version__}", "layer": "over-shot",
                                               "requestedEndFrame": int(header.end_frame)}}
        layer.pseudoRoot.SetInfo(UsdGeom.Tokens.upAxis, UsdGeom.Tokens.y if header.up_axis == "Y" else UsdGeom.Tokens.z)
        layer.pseudoRoot.SetInfo(UsdGeom.Tokens.metersPerUnit, float(header.meters_per_unit))
        self._header, self._layer, self._stage = header, layer, shot
        self._targets = [self._define(cloth.name, header) for cloth in header.cloths]

    def _define(self, name: str, header: CacheHeader) -> dict:
        cloth = self._cloths.get(name)
        if cloth is None:
            raise FormatError(f"{self.path}: cloth '{name}' is not a cloth of {self._shot.name}")
        prim_path = Sdf.Path(cloth.prim)
        spec = Sdf.CreatePrimInLayer(self._layer, prim_path)  # an `over`, ancestors included
        paths = {}
        for attr, type_name in (("points", Sdf.ValueTypeNames.Point3fArray), ("extent", Sdf.ValueTypeNames.Float3Array)):
            Sdf.AttributeSpec(spec, attr, type_name)
            paths[attr] = prim_path.AppendProperty(attr)
        if "velocities" in header.attributes:
            Sdf.AttributeSpec(spec, "velocities", Sdf.ValueTypeNames.Vector3fArray)
            paths["velocities"] = prim_path.AppendProperty("velocities")
        return {"paths": paths, "map": cloth.vertex_particle, "xformable": UsdGeom.Xformable(self._stage.GetPrimAtPath(prim_path))}

    def write_frame(self, frame: FrameData) -> None:
        self._check_next_frame(frame)
        self._write_whole_frame(frame.frame, lambda time: self._write_samples(frame, time))

    def _write_samples(self, frame: FrameData, time: float) -> None:
        for i, target in enumerate(self._targets):
            world_to_local = np.linalg.inv(np.array(target["xformable"].ComputeLocalToWorldTransform(Usd.TimeCode(time)), np.float64))
            world = np.asarray(frame.points[i], np.float64)[target["map"]]
            local = as_points(world @ world_to_local[:3, :3] + world_to_local[3, :3])
            self._layer.SetTimeSample(target["paths"]["points"], time, vec3f_array(local))
            self._layer.SetTimeSample(target["paths"]["extent"], time, vec3f_array(points_extent(local)))
            if "velocities" in target["paths"] and frame.velocities is not None:
                velocities = np.asarray(frame.velocities[i], np.float64)[target["map"]] @ world_to_local[:3, :3]
                self._layer.SetTimeSample(target["paths"]["velocities"], time, vec3f_array(as_points(velocities)))

    def _drop_handles(self) -> None:
        self._stage = None
        self._targets = []
