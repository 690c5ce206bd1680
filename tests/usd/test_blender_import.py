"""Blender opens the layer a shot bakes into: the cloth's points it shows at a frame are pxr's.

Optional: runs where ``bpy`` (Blender as a Python module, ``pip install bpy``; wheels exist for
the Python each Blender release builds with) imports, skipped elsewhere. A tiny shot (a
UsdSkel-skinned body and a pinned strip) is baked into a layer over the shot; Blender's USD
importer reads that layer, and at several frames the garment's evaluated vertices (its
mesh-sequence-cache modifier reading the time-sampled points) are compared with pxr's world
points of the same composed stage, through the conversions Blender's importer applies: a Y-up
stage is turned to Blender's Z up ((x, y, z) -> (x, -z, y)) and, with "Apply Unit Conversion
Scale" (the default), lengths are multiplied by ``metersPerUnit`` (``clothtool.io.blender_hints``
says what the importer does not take).
"""

from __future__ import annotations

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from pxr import Usd, UsdGeom  # noqa: E402  (after the skip: bpy decides whether this file runs)

from clothtool.bake import bake  # noqa: E402
from clothtool.io.cache import CacheOptions  # noqa: E402
from clothtool.io.usdshot import ShotLayerWriter  # noqa: E402
from clothtool.loading import load_usd_scene  # noqa: E402
from tests.usd.shots import add_cloth, add_skinned_body, new_stage  # noqa: E402

FRAMES = (1, 6)
CLOTH = "/Shot/Cloth"


def _blender_from_usd(points: np.ndarray, up_axis: str, meters_per_unit: float) -> np.ndarray:
    """Where Blender's importer puts USD world points: metres, Z up."""
    x, y, z = (np.asarray(points, np.float64) * meters_per_unit).T
    return np.stack([x, -z, y], axis=1) if up_axis == "Y" else np.stack([x, y, z], axis=1)


def _bake_layer(folder, up_axis: str, meters_per_unit: float):
    shot = folder / "shot.usda"
    stage = new_stage(shot, up_axis=up_axis, meters_per_unit=meters_per_unit, frames=FRAMES)
    add_skinned_body(stage, "/Shot/Char", FRAMES)
    add_cloth(stage, columns=5, rows=4, size=0.15, offset=(0.0, 0.95, 0.1))
    stage.SetDefaultPrim(stage.GetPrimAtPath("/Shot"))
    stage.GetRootLayer().Save()
    scene = load_usd_scene(shot, ["solver.frequency=240"])
    layer = folder / "out" / "cloth.usdc"
    layer.parent.mkdir()
    bake(scene, ShotLayerWriter(layer, scene, CacheOptions()))
    return layer


def _pxr_world(layer, frame: int) -> np.ndarray:
    stage = Usd.Stage.Open(str(layer))
    mesh = UsdGeom.Mesh(stage.GetPrimAtPath(CLOTH))
    local = np.array(mesh.GetPointsAttr().Get(Usd.TimeCode(frame)), np.float64)
    m = np.array(mesh.ComputeLocalToWorldTransform(Usd.TimeCode(frame)), np.float64)
    return local @ m[:3, :3] + m[3, :3]


def _blender_cloth():
    """The object whose mesh-sequence-cache modifier reads the garment prim."""
    for obj in bpy.data.objects:
        for modifier in obj.modifiers:
            if modifier.type == "MESH_SEQUENCE_CACHE" and modifier.object_path == CLOTH:
                return obj
    names = {obj.name: [m.type for m in obj.modifiers] for obj in bpy.data.objects}
    raise AssertionError(f"Blender imported no animated mesh for {CLOTH}: {names}")


def _blender_world(obj, frame: int) -> np.ndarray:
    bpy.context.scene.frame_set(frame)
    evaluated = obj.evaluated_get(bpy.context.evaluated_depsgraph_get())
    mesh = evaluated.to_mesh()
    try:
        local = np.empty(len(mesh.vertices) * 3)
        mesh.vertices.foreach_get("co", local)
        local = local.reshape(-1, 3)
        m = np.array(evaluated.matrix_world, np.float64)
        return local @ m[:3, :3].T + m[:3, 3]
    finally:
        evaluated.to_mesh_clear()


@pytest.mark.parametrize("up_axis, meters_per_unit", [("Y", 1.0), ("Z", 0.01)])
def test_blender_shows_the_baked_cloth_where_pxr_does(out_dir, up_axis, meters_per_unit):
    layer = _bake_layer(out_dir, up_axis, meters_per_unit)
    bpy.ops.wm.read_factory_settings(use_empty=True)
    assert bpy.ops.wm.usd_import(filepath=str(layer)) == {"FINISHED"}
    cloth = _blender_cloth()
    assert (bpy.context.scene.frame_start, bpy.context.scene.frame_end) == FRAMES  # "Set Frame Range"
    first = None
    for frame in (1, 3, 4, 6):
        expected = _blender_from_usd(_pxr_world(layer, frame), up_axis, meters_per_unit)
        shown = _blender_world(cloth, frame)
        assert shown.shape == expected.shape
        # float32 points through Blender's float32 matrices: a few ulps of the shot's unit (7e-8 m seen)
        np.testing.assert_allclose(shown, expected, atol=1e-6 * meters_per_unit)
        first = shown if first is None else first
    assert np.abs(shown - first).max() > 1e-4 * meters_per_unit  # the frames differ: Blender reads the samples
